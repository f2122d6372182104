//! Low-level numerical solvers shared across the crate: [`lm`], the one bounded
//! Levenberg–Marquardt loop that the power fit, the consistent projection and the inverse
//! kinematics run; [`dot`], the inner product of the power model's hot loops; and
//! [`scaled_divided_differences`], the differences of samples at uneven times.

pub mod lm;

/// `sum_k a_k b_k` over the shorter of `a` and `b`, in four partial sums: a single running
/// sum is one chain of dependent additions, which the compiler may not reorder.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let len = a.len().min(b.len());
    let (ca, cb) = (a[..len].chunks_exact(4), b[..len].chunks_exact(4));
    let rest: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    let mut acc = [0.0; 4];
    for (x, y) in ca.zip(cb) {
        for j in 0..4 {
            acc[j] += x[j] * y[j];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + rest
}

/// The `p`-th divided differences of the samples `x` at the times `t` (s, strictly
/// increasing), each over the samples `k..=k+p` and scaled to unit variance under white noise
/// of unit variance: `sum_j w_j x_j / |w|` with `w_j = 1 / prod_(l != j) (t_j - t_l)`, in the
/// unit of `x`. Like the plain difference `Δ^p x / sqrt(C(2p, p))`, which it is at evenly
/// spaced times (to rounding), it is blind to polynomials of degree below `p`: what is left
/// is the part of the samples that no such polynomial through `p + 1` of them follows
/// (noise, or a motion the sampling does not resolve). `len - p` values, none for
/// `len <= p`.
pub fn scaled_divided_differences(t: &[f64], x: &[f64], p: usize) -> Vec<f64> {
    let len = t.len().min(x.len());
    let mut w = vec![0.0; p + 1];
    (0..len.saturating_sub(p))
        .map(|k| {
            // Times scaled to the window's span: the scale cancels in `w / |w|`.
            let span = t[k + p] - t[k];
            for (j, wj) in w.iter_mut().enumerate() {
                let tj = t[k + j];
                *wj = 1.0
                    / (0..=p)
                        .filter(|&l| l != j)
                        .map(|l| (tj - t[k + l]) / span)
                        .product::<f64>();
            }
            let norm = w.iter().map(|v| v * v).sum::<f64>().sqrt();
            w.iter()
                .zip(&x[k..=k + p])
                .map(|(wj, xj)| wj * xj)
                .sum::<f64>()
                / norm
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn dot_sums_every_product_with_its_remainder() {
        let a: Vec<f64> = (1..=7).map(f64::from).collect();
        let b = [1.0, -1.0, 2.0, 0.5, 3.0, -2.0, 1.0];
        let expected: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        assert_eq!(super::dot(&a, &b), expected);
        assert_eq!(super::dot(&a[..3], &b), 1.0 - 2.0 + 6.0);
        assert_eq!(super::dot(&[], &b), 0.0);
    }
}
