//! A trajectory sampled at a fixed rate as the CSV table `excite` writes and `simulate
//! --trajectory` / `predict --trajectory` read: `t_s`, `q1_rad..qn_rad`,
//! `dq1_rad_s..dqn_rad_s`, `ddq1_rad_s2..ddqn_rad_s2`.

use crate::error::{Error, Result};
use crate::io::table::to_csv;

use super::Trajectory;

/// `traj` sampled every `1 / rate_hz` s from 0 to its duration (rounded to whole samples),
/// as CSV text with the columns of the module docs.
///
/// Errors ([`Error::InvalidInput`]): a rate or duration that is not finite and positive.
pub fn trajectory_csv(traj: &dyn Trajectory, rate_hz: f64) -> Result<String> {
    let duration = traj.duration();
    if !(rate_hz.is_finite() && rate_hz > 0.0 && duration.is_finite() && duration > 0.0) {
        return Err(Error::InvalidInput(format!(
            "sampling a {duration} s trajectory at {rate_hz} Hz: both must be finite and positive"
        )));
    }
    let n = traj.dof();
    let rows = (duration * rate_hz).round() as usize + 1;
    let mut cols = vec![Vec::with_capacity(rows); 1 + 3 * n];
    let (mut q, mut dq, mut ddq) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for k in 0..rows {
        let t = k as f64 / rate_hz;
        traj.sample(t, &mut q, &mut dq, &mut ddq);
        cols[0].push(t);
        for i in 0..n {
            cols[1 + i].push(q[i]);
            cols[1 + n + i].push(dq[i]);
            cols[1 + 2 * n + i].push(ddq[i]);
        }
    }
    let headers: Vec<String> = std::iter::once("t_s".to_string())
        .chain((1..=n).map(|i| format!("q{i}_rad")))
        .chain((1..=n).map(|i| format!("dq{i}_rad_s")))
        .chain((1..=n).map(|i| format!("ddq{i}_rad_s2")))
        .collect();
    Ok(to_csv(&headers, &cols))
}
