//! The power model of one observation: the arm's power or one motor's, clipped where the
//! signal cannot go negative, and its gradient in the parameters.

use nalgebra::DVector;

use super::samples::Samples;

impl Samples {
    /// Predicted power (W, clipped when the arm's signal is) of observation `m` with
    /// parameters `z`, and optionally its gradient with respect to `z`.
    ///
    /// Allocates nothing: it runs once per observation in every iteration of every fit.
    pub(super) fn power(&self, m: usize, z: &DVector<f64>, grad: Option<&mut [f64]>) -> f64 {
        if self.span[m] > 1 {
            return self.mean_power(m, z, grad);
        }
        let (n, nb) = (self.n, self.nb);
        let p0 = z[self.constant(m)];
        let z = z.as_slice();
        let (theta, copper) = (&z[..nb], &z[nb..nb + n]);
        let (wb, v, known) = self.state_rows(self.state[m]);
        let tau = |i: usize| torque(wb, known, theta, i);
        if let Some(i) = self.motor[m] {
            let t = tau(i);
            if let Some(g) = grad {
                g.fill(0.0);
                let d = v[i] + 2.0 * copper[i] * t;
                for (gk, a) in g[..nb].iter_mut().zip(&wb[i * nb..(i + 1) * nb]) {
                    *gk = d * a;
                }
                g[nb + i] = t * t;
                g[self.constant(m)] = 1.0;
            }
            return p0 + (v[i] + copper[i] * t) * t;
        }
        let Some(g) = grad else {
            let p = p0
                + (0..n)
                    .map(|i| {
                        let t = tau(i);
                        (v[i] + copper[i] * t) * t
                    })
                    .sum::<f64>();
            return if self.clipped && p < 0.0 { 0.0 } else { p };
        };
        g.fill(0.0);
        let mut p = p0;
        for i in 0..n {
            let t = tau(i);
            p += (v[i] + copper[i] * t) * t;
            let d = v[i] + 2.0 * copper[i] * t;
            for (gk, a) in g[..nb].iter_mut().zip(&wb[i * nb..(i + 1) * nb]) {
                *gk += d * a;
            }
            g[nb + i] = t * t;
        }
        g[self.constant(m)] = 1.0;
        if self.clipped && p < 0.0 {
            g.fill(0.0);
            return 0.0;
        }
        p
    }

    /// [`Samples::power`] of an observation that averages its `span` states: the mean of
    /// each state's power (clipped state by state, as the meter averages what the bus
    /// carries), and optionally its gradient.
    fn mean_power(&self, m: usize, z: &DVector<f64>, mut grad: Option<&mut [f64]>) -> f64 {
        let (n, nb) = (self.n, self.nb);
        let span = self.span[m];
        let w = 1.0 / span as f64;
        let c0 = self.constant(m);
        let p0 = z[c0];
        let zs = z.as_slice();
        let (theta, copper) = (&zs[..nb], &zs[nb..nb + n]);
        if let Some(g) = grad.as_deref_mut() {
            g.fill(0.0);
        }
        let joints = match self.motor[m] {
            Some(i) => i..i + 1,
            None => 0..n,
        };
        let clip = self.clipped && self.motor[m].is_none();
        let mut mean = 0.0;
        for st in self.state[m]..self.state[m] + span {
            let (wb, v, known) = self.state_rows(st);
            // The state's power, its gradient added as it goes (each torque computed once);
            // a state the clip takes is taken out again.
            let add = |g: Option<&mut [f64]>, w: f64| -> f64 {
                let mut p = p0;
                let mut g = g;
                for i in joints.clone() {
                    let t = torque(wb, known, theta, i);
                    p += (v[i] + copper[i] * t) * t;
                    if let Some(g) = g.as_deref_mut() {
                        let d = w * (v[i] + 2.0 * copper[i] * t);
                        for (gk, a) in g[..nb].iter_mut().zip(&wb[i * nb..(i + 1) * nb]) {
                            *gk += d * a;
                        }
                        g[nb + i] += w * t * t;
                    }
                }
                if let Some(g) = g {
                    g[c0] += w;
                }
                p
            };
            let p = add(grad.as_deref_mut(), w);
            if clip && p < 0.0 {
                if grad.is_some() {
                    add(grad.as_deref_mut(), -w);
                }
                continue;
            }
            mean += w * p;
        }
        mean
    }

    /// State `st`'s base regressor rows (`n x nb`, row-major), joint speeds (rad/s) and known
    /// payload torques (N m).
    fn state_rows(&self, st: usize) -> (&[f64], &[f64], &[f64]) {
        let (n, nb) = (self.n, self.nb);
        (
            &self.wb[st * n * nb..(st + 1) * n * nb],
            &self.dq[st * n..(st + 1) * n],
            &self.tau_known[st * n..(st + 1) * n],
        )
    }
}

/// Joint `i`'s torque (N m) from a state's regressor rows `wb` (`theta.len()` columns each),
/// its known payload torques and the base parameters `theta`.
fn torque(wb: &[f64], known: &[f64], theta: &[f64], i: usize) -> f64 {
    let nb = theta.len();
    let row = &wb[i * nb..(i + 1) * nb];
    row.iter().zip(theta).map(|(a, b)| a * b).sum::<f64>() + known[i]
}
