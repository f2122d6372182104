//! The power model of one observation: the arm's power or one motor's, clipped at its floor
//! where the signal cannot go lower, and its gradient in the parameters.

use nalgebra::DVector;

use super::samples::Samples;

impl Samples {
    /// Predicted power (W, clipped at its floor when the arm's signal is) of observation `m` with
    /// parameters `z`, and optionally its gradient with respect to `z`.
    ///
    /// Allocates nothing: it runs once per observation in every iteration of every fit.
    pub(super) fn power(&self, m: usize, z: &DVector<f64>, grad: Option<&mut [f64]>) -> f64 {
        if self.span[m] > 1 {
            return self.mean_power(m, z, grad);
        }
        let (n, nb) = (self.n, self.nb);
        let p0 = z[self.constant(m)];
        let losses = Losses::of(z.as_slice(), nb, n, self.gear);
        let (wb, v, known) = self.state_rows(self.state[m]);
        let tau = |i: usize| torque(wb, known, losses.theta, i);
        if let Some(i) = self.motor[m] {
            let j = losses.joint(i, v[i], tau(i));
            if let Some(g) = grad {
                g.fill(0.0);
                j.add_gradient(g, wb, nb, n, i, 1.0);
                g[self.constant(m)] = 1.0;
            }
            return p0 + j.power;
        }
        let (floor, dfloor) = self.floor_at(p0);
        let Some(g) = grad else {
            let p = p0
                + (0..n)
                    .map(|i| losses.joint(i, v[i], tau(i)).power)
                    .sum::<f64>();
            return if self.clipped && p < floor { floor } else { p };
        };
        g.fill(0.0);
        let mut p = p0;
        for (i, &dq) in v.iter().enumerate() {
            let j = losses.joint(i, dq, tau(i));
            p += j.power;
            j.add_gradient(g, wb, nb, n, i, 1.0);
        }
        g[self.constant(m)] = 1.0;
        if self.clipped && p < floor {
            g.fill(0.0);
            g[self.constant(m)] = dfloor;
            return floor;
        }
        p
    }

    /// The floor under the clipped arm's signal (W) with the arm's standby `p0_w`, and its
    /// derivative in `p0_w` ([`super::samples::Floor::at`]; 0 and 0 without a floor).
    fn floor_at(&self, p0_w: f64) -> (f64, f64) {
        self.floor.map_or((0.0, 0.0), |f| f.at(p0_w))
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
        let losses = Losses::of(z.as_slice(), nb, n, self.gear);
        if let Some(g) = grad.as_deref_mut() {
            g.fill(0.0);
        }
        let joints = match self.motor[m] {
            Some(i) => i..i + 1,
            None => 0..n,
        };
        let clip = self.clipped && self.motor[m].is_none();
        let (floor, dfloor) = self.floor_at(p0);
        let mut mean = 0.0;
        for st in self.state[m]..self.state[m] + span {
            let (wb, v, known) = self.state_rows(st);
            // The state's power, its gradient added as it goes (each torque computed once);
            // a state the clip takes is taken out again.
            let add = |g: Option<&mut [f64]>, w: f64| -> f64 {
                let mut p = p0;
                let mut g = g;
                for i in joints.clone() {
                    let j = losses.joint(i, v[i], torque(wb, known, losses.theta, i));
                    p += j.power;
                    if let Some(g) = g.as_deref_mut() {
                        j.add_gradient(g, wb, nb, n, i, w);
                    }
                }
                if let Some(g) = g {
                    g[c0] += w;
                }
                p
            };
            let p = add(grad.as_deref_mut(), w);
            if clip && p < floor {
                if let Some(g) = grad.as_deref_mut() {
                    add(Some(&mut *g), -w);
                    g[c0] += w * dfloor;
                }
                mean += w * floor;
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
    crate::numerics::dot(row, theta) + known[i]
}

/// The parameters of `z` one joint's power needs: the base parameters, and the copper and
/// (when the parameters hold them) gear-friction coefficients.
struct Losses<'a> {
    theta: &'a [f64],
    copper: &'a [f64],
    gear: Option<&'a [f64]>,
}

impl<'a> Losses<'a> {
    /// The slices of `z = [theta, c, g, ..]` (`nb` base parameters, `n` joints, `g` when
    /// `gear`).
    fn of(z: &'a [f64], nb: usize, n: usize, gear: bool) -> Self {
        Losses {
            theta: &z[..nb],
            copper: &z[nb..nb + n],
            gear: gear.then(|| &z[nb + n..nb + 2 * n]),
        }
    }

    /// Joint `i`'s power at speed `dq` (rad/s) and torque `tau` (N m):
    /// `dq tau + c tau^2 + g |dq tau|`.
    fn joint(&self, i: usize, dq: f64, tau: f64) -> JointPower {
        let c = self.copper[i];
        let mech = dq * tau;
        let (power, dp_dtau) = (mech + c * tau * tau, dq + 2.0 * c * tau);
        match self.gear {
            Some(g) => JointPower {
                power: power + g[i] * mech.abs(),
                dp_dtau: dp_dtau + g[i] * sign(mech) * dq,
                tau,
                mech_abs: Some(mech.abs()),
            },
            None => JointPower {
                power,
                dp_dtau,
                tau,
                mech_abs: None,
            },
        }
    }
}

/// One joint's power and what its gradient needs.
struct JointPower {
    /// `dq tau + c tau^2 + g |dq tau|`, W.
    power: f64,
    /// Its derivative in the torque, W/(N m).
    dp_dtau: f64,
    /// The torque, N m.
    tau: f64,
    /// `|dq tau|`, W: the derivative in the gear-friction coefficient (`None` without it).
    mech_abs: Option<f64>,
}

impl JointPower {
    /// Add `w` times this power's gradient in `z` to `g` (joint `i`'s regressor row in `wb`,
    /// `nb` base parameters, `n` joints).
    fn add_gradient(&self, g: &mut [f64], wb: &[f64], nb: usize, n: usize, i: usize, w: f64) {
        let d = w * self.dp_dtau;
        for (gk, a) in g[..nb].iter_mut().zip(&wb[i * nb..(i + 1) * nb]) {
            *gk += d * a;
        }
        g[nb + i] += w * self.tau * self.tau;
        if let Some(a) = self.mech_abs {
            g[nb + n + i] += w * a;
        }
    }
}

/// The sign of `x`, 0 at 0 (the subgradient of `|x|` the fit takes there).
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::super::samples::PieceId;
    use super::*;

    /// Two joints, two base parameters, two states; observation 0 the arm's power at state 0,
    /// 1 motor 2's there, 2 the arm's averaged over both states.
    fn samples() -> Samples {
        Samples {
            n: 2,
            nb: 2,
            wb: vec![0.7, -1.3, 0.4, 2.1, -0.5, 0.9, 1.6, 0.3],
            dq: vec![1.2, -0.8, -0.6, 1.5],
            tau_known: vec![0.3, -0.2, 0.0, 0.5],
            state: vec![0, 0, 0],
            span: vec![1, 1, 2],
            motor: vec![None, Some(1), None],
            motors: true,
            gear: true,
            series: vec![0, 1, 0],
            y: vec![1.0, 2.0, 3.0],
            fit: vec![true; 3],
            piece: vec![PieceId { log: 0, block: 0 }; 3],
            fold: vec![0; 3],
            folds: 1,
            folds_are_logs: false,
            clipped: false,
            prior: None,
            floor: None,
        }
    }

    #[test]
    fn the_power_gradient_is_the_power_models_derivative() {
        let s = samples();
        // z = [theta (2), c (2), g (2), P0_1, P0_2, P0].
        let z = DVector::from_vec(vec![3.0, -2.0, 0.02, 0.05, 0.03, 0.01, 1.5, 2.5, 7.0]);
        for m in 0..s.len() {
            let mut g = vec![0.0; z.len()];
            let p = s.power(m, &z, Some(&mut g));
            assert!((p - s.power(m, &z, None)).abs() < 1e-12);
            for k in 0..z.len() {
                let h = 1e-6;
                let (mut up, mut down) = (z.clone(), z.clone());
                up[k] += h;
                down[k] -= h;
                let fd = (s.power(m, &up, None) - s.power(m, &down, None)) / (2.0 * h);
                assert!(
                    (fd - g[k]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "observation {m}, parameter {k}: gradient {} against {fd}",
                    g[k]
                );
            }
        }
        // Motor 2 at state 0: tau = 0.4 * 3 + 2.1 * (-2) - 0.2 = -3.2 N m at -0.8 rad/s.
        let (tau, dq): (f64, f64) = (-3.2, -0.8);
        let expected = dq * tau + 0.05 * tau * tau + 0.01 * (dq * tau).abs() + 2.5;
        assert!((s.power(1, &z, None) - expected).abs() < 1e-12);
    }

    /// A clipped arm's observation the model puts below the floor reads the floor, which moves
    /// with the standby while it lies between 0 and the lowest level seen, and is fixed once
    /// read from the logs.
    #[test]
    fn a_clipped_arm_reads_its_floor() {
        use super::super::floor::Floor;
        let mut s = samples();
        s.clipped = true;
        // theta as in the gradient's test, negated: the arm regenerates at state 0.
        let z = DVector::from_vec(vec![-3.0, 2.0, 0.02, 0.05, 0.03, 0.01, 1.5, 2.5, 7.0]);
        s.floor = Some(Floor::Fixed(f64::NEG_INFINITY));
        let joints = s.power(0, &z, None) - 7.0;
        assert!(joints < -1.0, "the joints' power {joints} W");
        // A floor above the model's power: the standby less the drive file's, below what was
        // seen.
        let floor = 7.0 + 0.5 * joints;
        s.floor = Some(Floor::Standby {
            standby_w: 7.0 - floor,
            lowest_w: 100.0,
        });
        let mut g = vec![0.0; z.len()];
        assert_eq!(s.power(0, &z, Some(&mut g)), floor);
        let mut expected = vec![0.0; z.len()];
        expected[8] = 1.0;
        assert_eq!(g, expected);
        s.floor = Some(Floor::Fixed(floor));
        assert_eq!(s.power(0, &z, Some(&mut g)), floor);
        assert!(g.iter().all(|v| *v == 0.0));
        // The averaged observation is the mean of its states, each clipped at the floor.
        s.floor = Some(Floor::Fixed(f64::NEG_INFINITY));
        let states: Vec<f64> = (0..2)
            .map(|k| {
                let mut one = samples();
                one.state = vec![k; 3];
                one.span = vec![1; 3];
                one.power(2, &z, None)
            })
            .collect();
        // A floor between them: one state clipped, the other not.
        let between = 0.5 * (states[0] + states[1]);
        assert!(
            (states[0] - states[1]).abs() > 0.01,
            "states at {states:?} W"
        );
        s.floor = Some(Floor::Fixed(between));
        let mean = states.iter().map(|p| 0.5 * p.max(between)).sum::<f64>();
        assert!((s.power(2, &z, None) - mean).abs() < 1e-12);
    }
}
