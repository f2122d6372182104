//! Longest-first scheduling of independent jobs on rayon's threads, so a batch ends without a
//! long tail: each thread takes the longest job not yet started (greedy LPT, within 4/3 of
//! the best finish time), where a plain parallel iterator splits the list into contiguous
//! halves and may leave one long job to run alone at the end.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

/// Run `job` on every item of `items`, longest `cost` first, on rayon's current thread pool;
/// results in the order of `items`. `cost` is any estimate of a job's run time in a common
/// unit (e.g. simulated seconds); ties keep the order of `items`.
pub fn longest_first<T, R, C, F>(items: &[T], cost: C, job: F) -> Vec<R>
where
    T: Sync,
    R: Send,
    C: Fn(&T) -> f64 + Sync,
    F: Fn(&T) -> R + Sync,
{
    let costs: Vec<f64> = items.par_iter().map(&cost).collect();
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by(|&a, &b| costs[b].total_cmp(&costs[a]));
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<R>>> = Mutex::new((0..items.len()).map(|_| None).collect());
    (0..rayon::current_num_threads().max(1))
        .into_par_iter()
        .for_each(|_| {
            loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(&i) = order.get(k) else { break };
                let r = job(&items[i]);
                results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(r);
            }
        });
    results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .map(|r| r.expect("every job ran"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_job_runs_once_and_results_keep_the_input_order() {
        let items: Vec<usize> = (0..50).collect();
        let out = longest_first(&items, |&i| (i % 7) as f64, |&i| i * 2);
        assert_eq!(out, items.iter().map(|i| i * 2).collect::<Vec<_>>());
    }

    #[test]
    fn one_thread_runs_the_longest_first() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let started = Mutex::new(Vec::new());
        let items = [1.0, 5.0, 3.0, 5.0];
        pool.install(|| {
            longest_first(&items, |&c| c, |&c| started.lock().unwrap().push(c));
        });
        assert_eq!(started.into_inner().unwrap(), vec![5.0, 5.0, 3.0, 1.0]);
    }
}
