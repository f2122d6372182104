//! `excite_set`: an identification set designed together, as `powertwin excite --set N`.

use std::path::{Path, PathBuf};

use numpy::PyArray1;
use powertwin::identification::excitation_set::arm::{ArmSet, design as design_arm_set};
use powertwin::identification::excitation_set::export::{SetFiles, write_set};
use powertwin::model::payload::{check_rated, resolve};
use powertwin::trajectory::Trajectory;
use powertwin::trajectory::cell::Cell;
use powertwin::trajectory::limits::default_accel_limits;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::robot::PyRobot;
use crate::runs::array2;
use crate::{ctx, value_error};

/// `traj` sampled at `rate_hz` from 0 to its duration: t_s (s), q_rad, dq_rad_s, ddq_rad_s2.
fn sampled<'py>(
    py: Python<'py>,
    traj: &dyn Trajectory,
    dof: usize,
    rate_hz: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let n = (traj.duration() * rate_hz).round() as usize + 1;
    let t: Vec<f64> = (0..n).map(|k| k as f64 / rate_hz).collect();
    let mut cols = [
        vec![vec![0.0; n]; dof],
        vec![vec![0.0; n]; dof],
        vec![vec![0.0; n]; dof],
    ];
    let (mut q, mut dq, mut ddq) = (vec![0.0; dof], vec![0.0; dof], vec![0.0; dof]);
    for (k, &tk) in t.iter().enumerate() {
        traj.sample(tk, &mut q, &mut dq, &mut ddq);
        for j in 0..dof {
            cols[0][j][k] = q[j];
            cols[1][j][k] = dq[j];
            cols[2][j][k] = ddq[j];
        }
    }
    let d = PyDict::new(py);
    d.set_item("t_s", PyArray1::from_vec(py, t))?;
    d.set_item("q_rad", array2(py, &cols[0])?)?;
    d.set_item("dq_rad_s", array2(py, &cols[1])?)?;
    d.set_item("ddq_rad_s2", array2(py, &cols[2])?)?;
    Ok(d)
}

/// Design `n` excitations together for identification (as `powertwin excite --set N`):
/// `loads` one spec per excitation ("none", built-in names, payload files; '+' combines),
/// `cell` a cell TOML (default: the default workspace), `duration_s` s, `base_freq_hz` Hz,
/// `accel_limits` rad/s^2 per joint (default: the robot's). With `out`, writes the set's CSV
/// files and runs manifest there as the CLI does. Returns the trajectories sampled at
/// `rate_hz` and the stacked condition numbers.
#[pyfunction]
#[pyo3(signature = (robot, loads, cell, duration_s, base_freq_hz, harmonics, accel_limits, rounds, evals, seed, out, rate_hz))]
#[allow(clippy::too_many_arguments)]
pub fn excite_set<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    loads: Vec<String>,
    cell: Option<PathBuf>,
    duration_s: f64,
    base_freq_hz: f64,
    harmonics: usize,
    accel_limits: Option<Vec<f64>>,
    rounds: usize,
    evals: usize,
    seed: u64,
    out: Option<PathBuf>,
    rate_hz: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let r = &robot.robot;
    let rated = robot.drive()?.and_then(|d| d.rated_payload_kg());
    let mut payloads = Vec::with_capacity(loads.len());
    for (k, spec) in loads.iter().enumerate() {
        let p = (spec != "none")
            .then(|| resolve(spec, Path::new(".")))
            .transpose()
            .map_err(ctx(format!("--loads entry {} ('{spec}')", k + 1)))?;
        if let Some(p) = &p {
            check_rated(p.inertia.mass, rated, &format!("--loads '{spec}'")).map_err(ctx(""))?;
        }
        payloads.push(p);
    }
    let cell = match &cell {
        Some(path) => Cell::from_file(path).map_err(ctx(""))?,
        None => Cell::default(),
    };
    let set = ArmSet {
        payloads,
        duration_s,
        base_freq_hz,
        harmonics,
        accel_limits: accel_limits.unwrap_or_else(|| default_accel_limits(r)),
        rounds,
        max_evals: evals,
        seed,
    };
    let design = py.detach(|| -> PyResult<_> {
        let (_, design) = design_arm_set(r, &cell, &set)
            .map_err(ctx(format!("designing {} excitations", loads.len())))?;
        if let Some(dir) = &out {
            let trajectories: Vec<&dyn Trajectory> = design
                .trajectories
                .iter()
                .map(|t| t as &dyn Trajectory)
                .collect();
            let files = SetFiles {
                dir,
                rate_hz,
                urscript: false,
                payloads: &loads,
                payload_dir: Path::new("."),
                robot: r.name(),
            };
            write_set(&trajectories, &files)
                .map_err(ctx(format!("writing the set into {}", dir.display())))?;
        }
        Ok(design)
    })?;
    if design.trajectories.is_empty() {
        return Err(value_error("the design has no trajectory"));
    }
    let d = PyDict::new(py);
    let trajs = design
        .trajectories
        .iter()
        .map(|t| sampled(py, t, r.dof(), rate_hz))
        .collect::<PyResult<Vec<_>>>()?;
    d.set_item("trajectories", trajs)?;
    d.set_item("cond_initial", design.cond_initial)?;
    d.set_item("cond_final", design.cond_final)?;
    d.set_item("member_conds", design.member_conds.clone())?;
    Ok(d)
}
