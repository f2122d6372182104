//! Held-out motions of `powertwin validate`, one at a time (for `powertwin.distributed`),
//! and their join into the CLI's `validate --json`.

use std::path::PathBuf;

use powertwin::dataset::Format;
use powertwin::validation::heldout::{self, Heldout, HeldoutOptions};
use powertwin::validation::rig::Rig;
use powertwin::validation::score::{self, MotionResult, RouteSummary, Spread};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::model::{PyModel, inner};
use crate::robot::PyRobot;
use crate::runs::twin_options;
use crate::{ctx, parse, value_error};

/// The benchmark's options as `validate --count --seed --max-payload` makes them.
fn options(
    robot: &PyRobot,
    rated: Option<f64>,
    count: usize,
    seed: u64,
    max_payload: Option<f64>,
) -> PyResult<HeldoutOptions> {
    let Some(max_payload) = max_payload.or(rated) else {
        return Err(value_error(
            "the drive file gives no rated payload (rated_payload_kg): pass --max-payload KG, \
             the largest payload of the held-out motions",
        ));
    };
    if !(max_payload.is_finite() && max_payload > 0.0) {
        return Err(value_error(format!(
            "--max-payload {max_payload} must be a positive mass in kg"
        )));
    }
    powertwin::model::payload::check_rated(max_payload, rated, "--max-payload").map_err(ctx(""))?;
    if count == 0 {
        return Err(value_error("--count must be at least 1"));
    }
    Ok(HeldoutOptions {
        seed,
        ..HeldoutOptions::for_robot(&robot.robot, count, max_payload).map_err(ctx(""))?
    })
}

/// Held-out motion `k` (0-based) of `powertwin validate --count COUNT --seed SEED`: its twin
/// run (the CLI's noise seed) and its scores, as the CLI computes them; the motion's JSON
/// (as in the CLI's `motions`). With `out`, its dataset is written to
/// `out/datasets/heldout_NN_KIND` as the CLI writes it.
#[pyfunction]
#[pyo3(signature = (robot, model, k, count, seed, max_payload, opts, out, format))]
#[allow(clippy::too_many_arguments)]
pub fn validate_motion(
    py: Python<'_>,
    robot: &PyRobot,
    model: PyRef<'_, PyModel>,
    k: usize,
    count: usize,
    seed: u64,
    max_payload: Option<f64>,
    opts: &Bound<'_, PyDict>,
    out: Option<PathBuf>,
    format: &str,
) -> PyResult<String> {
    let setup = twin_options(opts)?.setup(robot, &[])?;
    let model = inner(&model);
    let opts = options(
        robot,
        setup.drive.rated_payload_kg(),
        count,
        seed,
        max_payload,
    )?;
    if k >= count {
        return Err(value_error(format!(
            "k={k}: the benchmark has {count} motions"
        )));
    }
    let format: Format = parse("format", format)?;
    let r = &robot.robot;
    py.detach(|| {
        let rig = Rig {
            plant: None,
            robot: r,
            urdf: robot.urdf.clone(),
            drive: &setup.drive,
            twin: setup.twin.clone(),
            sensor: setup.sensor,
        };
        let motions = heldout::motions(r, &opts).map_err(ctx(""))?;
        let m = &motions[k];
        let description = serde_json::json!({
            "kind": m.kind,
            "experiment": "held-out benchmark",
            "index": k + 1,
            "payload_kg": m.payload_kg,
            "tcp_speed_m_s": m.tcp_speed_m_s,
        });
        let ds = rig
            .run(
                m.trajectory.as_ref(),
                &m.events,
                10_000 + k as u64,
                description,
            )
            .map_err(|e| e.context(&format!("held-out motion {}", k + 1)))
            .map_err(ctx(""))?;
        let base = heldout::baseline(r, model, opts.baseline_efficiency).map_err(ctx(""))?;
        let result =
            score::heldout_motion(&rig, model, &base, k, m, &ds, &opts).map_err(ctx(""))?;
        if let Some(dir) = &out {
            let path = dir
                .join("datasets")
                .join(format!("heldout_{:02}_{}", result.index, result.kind));
            std::fs::create_dir_all(dir.join("datasets"))
                .map_err(|e| crate::os_error("creating", dir, &e))?;
            ds.write(&path, format)
                .map_err(ctx(format!("writing {}", path.display())))?;
        }
        serde_json::to_string(&result).map_err(|e| value_error(e.to_string()))
    })
}

/// `validate --json` of motions scored separately (`validate_motion`, JSON texts in order)
/// with the benchmark's `seed`: the summaries as the CLI computes them.
#[pyfunction]
pub fn validate_assemble(seed: u64, motions: Vec<String>) -> PyResult<String> {
    let motions: Vec<MotionResult> = motions
        .iter()
        .map(|m| serde_json::from_str(m).map_err(|e| value_error(format!("held-out motion: {e}"))))
        .collect::<PyResult<_>>()?;
    let h = Heldout {
        seed,
        from_log: RouteSummary::of(motions.iter().map(|m| &m.from_log)),
        from_plan: RouteSummary::of(motions.iter().map(|m| &m.from_plan)),
        baseline: RouteSummary::of(motions.iter().map(|m| &m.baseline)),
        power_rmse_w: Spread::of(motions.iter().map(|m| m.power_rmse_w)),
        plan_power_rmse_w: Spread::of(motions.iter().map(|m| m.plan_power_rmse_w)),
        baseline_power_rmse_w: Spread::of(motions.iter().map(|m| m.baseline_power_rmse_w)),
        motions,
    };
    serde_json::to_string_pretty(&h).map_err(|e| value_error(e.to_string()))
}
