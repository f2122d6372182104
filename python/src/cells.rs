//! A sweep cell back from its JSON (sweep.json's form), for joining cells that ran in other
//! processes.

use powertwin::trajectory::linear_move::{SlowReason, SlowedSegment};
use powertwin::twin::TorqueLimitHit;
use powertwin::validation::sweep::Cell;
use pyo3::PyResult;
use serde_json::Value;

use crate::value_error;

fn f64_of(v: &Value, key: &str) -> PyResult<f64> {
    match v.get(key) {
        // A non-finite value is written as null.
        Some(Value::Null) => Ok(f64::NAN),
        Some(x) => x
            .as_f64()
            .ok_or_else(|| value_error(format!("sweep cell: {key} is not a number"))),
        None => Err(value_error(format!("sweep cell: no {key}"))),
    }
}

fn opt_f64(v: &Value, key: &str) -> PyResult<Option<f64>> {
    match v.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(_) => f64_of(v, key).map(Some),
    }
}

fn usize_of(v: &Value, key: &str) -> PyResult<usize> {
    v.get(key)
        .and_then(Value::as_u64)
        .map(|n| n as usize)
        .ok_or_else(|| value_error(format!("sweep cell: {key} is not a count")))
}

fn array<'a>(v: &'a Value, key: &str) -> PyResult<&'a Vec<Value>> {
    v.get(key)
        .and_then(Value::as_array)
        .ok_or_else(|| value_error(format!("sweep cell: {key} is not a list")))
}

fn slowed(s: &Value) -> PyResult<SlowedSegment> {
    Ok(SlowedSegment {
        segment: usize_of(s, "segment")?,
        commanded_m_s: f64_of(s, "commanded_m_s")?,
        used_m_s: f64_of(s, "used_m_s")?,
        limiting_joint: usize_of(s, "limiting_joint")?,
        reason: match s.get("reason").and_then(Value::as_str) {
            Some("joint_velocity") => SlowReason::JointVelocity,
            Some("joint_acceleration") => SlowReason::JointAcceleration,
            other => return Err(value_error(format!("sweep cell: slow reason {other:?}"))),
        },
    })
}

fn hit(h: &Value) -> PyResult<TorqueLimitHit> {
    Ok(TorqueLimitHit {
        joint: h
            .get("joint")
            .and_then(Value::as_str)
            .ok_or_else(|| value_error("sweep cell: torque limit hit without joint"))?
            .to_string(),
        first_t_s: f64_of(h, "first_t_s")?,
        steps: usize_of(h, "steps")?,
    })
}

/// The cell of `text` (its JSON as `sweep_cell` returns it).
pub fn cell_from_json(text: &str) -> PyResult<Cell> {
    let v: Value =
        serde_json::from_str(text).map_err(|e| value_error(format!("sweep cell: {e}")))?;
    Ok(Cell {
        speed_m_s: f64_of(&v, "speed_m_s")?,
        load_kg: f64_of(&v, "load_kg")?,
        cycle_time_s: f64_of(&v, "cycle_time_s")?,
        simulated_j: f64_of(&v, "simulated_J")?,
        simulated_grid_j: f64_of(&v, "simulated_grid_J")?,
        predicted_j: opt_f64(&v, "predicted_J")?,
        predicted_grid_j: opt_f64(&v, "predicted_grid_J")?,
        error_pct: opt_f64(&v, "error_pct")?,
        slowed: array(&v, "slowed")?
            .iter()
            .map(slowed)
            .collect::<PyResult<_>>()?,
        max_tracking_error_rad: f64_of(&v, "max_tracking_error_rad")?,
        torque_limit_hits: array(&v, "torque_limit_hits")?
            .iter()
            .map(hit)
            .collect::<PyResult<_>>()?,
        flagged: v
            .get("flagged")
            .and_then(Value::as_bool)
            .ok_or_else(|| value_error("sweep cell: flagged is not a bool"))?,
    })
}
