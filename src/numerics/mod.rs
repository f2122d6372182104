//! Low-level numerical solvers shared across the crate: [`lm`], the one bounded
//! Levenberg–Marquardt loop that the power fit, the consistent projection and the inverse
//! kinematics run; and [`dot`], the inner product of the power model's hot loops.

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
