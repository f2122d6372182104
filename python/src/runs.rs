//! Twin runs (`simulate`, dataset items) and logs (`read_log`, `read_dataset`, arrays).

use std::path::{Path, PathBuf};

use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use powertwin::dataset::bulk::{BulkFamily, BulkSpec, item};
use powertwin::dataset::generate::{RunSpec, simulate as twin_simulate};
use powertwin::dataset::{Dataset, Format};
use powertwin::measurement::Log;
use powertwin::measurement::columns::ColumnMap;
use powertwin::measurement::read::{ReadOptions, read_log as lib_read_log};
use powertwin::model::payload::{PayloadEvent, resolve};
use powertwin::trajectory::sampled::Sampled;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::json;

use crate::robot::{PyRobot, TwinOptions};
use crate::{ctx, parse, value_error};

/// A measured log: sample times (s), joint positions (rad), the arm's power (W) of one kind
/// (`signal`: total, bus or grid), optionally each motor's power (W), and the payloads the
/// user knows of.
#[pyclass(name = "Log", module = "powertwin._powertwin", frozen)]
#[derive(Clone)]
pub struct PyLog {
    pub log: Log,
}

/// Rows of `a` (n x m) as joint-major series (m series of n).
fn columns_of(a: &PyReadonlyArray2<'_, f64>) -> Vec<Vec<f64>> {
    let v = a.as_array();
    (0..v.ncols()).map(|j| v.column(j).to_vec()).collect()
}

/// Joint-major series (m of n) as an n x m array.
pub fn array2<'py>(py: Python<'py>, cols: &[Vec<f64>]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = cols.first().map_or(0, Vec::len);
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|k| cols.iter().map(|c| c[k]).collect())
        .collect();
    if rows.is_empty() {
        return Ok(PyArray2::zeros(py, [0, cols.len()], false));
    }
    PyArray2::from_vec2(py, &rows).map_err(|e| value_error(e.to_string()))
}

#[pymethods]
impl PyLog {
    /// A log from arrays (checked by the Python layer for shape and dtype): `t_s` (n,),
    /// `q_rad` (n, dof), `power_w` (n,) of kind `signal`, `motor_power_w` (n, dof) or None.
    #[staticmethod]
    #[pyo3(signature = (t_s, q_rad, power_w, signal, motor_power_w=None, power_averaged=false, source="arrays".to_string()))]
    fn _from_arrays(
        t_s: PyReadonlyArray1<'_, f64>,
        q_rad: PyReadonlyArray2<'_, f64>,
        power_w: PyReadonlyArray1<'_, f64>,
        signal: &str,
        motor_power_w: Option<PyReadonlyArray2<'_, f64>>,
        power_averaged: bool,
        source: String,
    ) -> PyResult<PyLog> {
        let log = Log {
            source,
            robot: None,
            t_s: t_s.as_slice()?.to_vec(),
            q_rad: columns_of(&q_rad),
            dq_rad_s: None,
            power_w: power_w.as_slice()?.to_vec(),
            signal: parse("signal", signal)?,
            motor_power_w: motor_power_w.as_ref().map(columns_of),
            power_averaged,
            payloads: Vec::new(),
        };
        log.validate().map_err(ctx(""))?;
        Ok(PyLog { log })
    }

    /// This log with a known payload at the flange throughout (`None`: no payload): built-in
    /// names or payload TOML files, joined by '+' or given as a list (as the CLI's
    /// `--payload`).
    #[pyo3(signature = (payload))]
    fn with_payload(&self, payload: Option<Vec<String>>) -> PyResult<PyLog> {
        let mut log = self.log.clone();
        log.payloads = match payload {
            None => Vec::new(),
            Some(p) if p.is_empty() => Vec::new(),
            Some(p) => vec![PayloadEvent {
                t_s: f64::NEG_INFINITY,
                payload: Some(resolve(&p.join("+"), Path::new(".")).map_err(ctx(""))?),
            }],
        };
        Ok(PyLog { log })
    }

    /// Where the log came from (a file or dataset path).
    #[getter]
    fn source(&self) -> String {
        self.log.source.clone()
    }
    /// Sample times, s, shape (n,).
    #[getter]
    fn t_s<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.log.t_s)
    }
    /// Joint positions, rad, shape (n, dof).
    #[getter]
    fn q_rad<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        array2(py, &self.log.q_rad)
    }
    /// The arm's measured power, W, shape (n,) (kind: `signal`).
    #[getter]
    fn power_w<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.log.power_w)
    }
    /// Each motor's power, W, shape (n, dof), or None.
    #[getter]
    fn motor_power_w<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        self.log
            .motor_power_w
            .as_ref()
            .map(|m| array2(py, m))
            .transpose()
    }
    /// What the power is: "total", "bus" or "grid".
    #[getter]
    fn signal(&self) -> String {
        self.log.signal.name().to_string()
    }
    /// Number of joints.
    #[getter]
    fn dof(&self) -> usize {
        self.log.dof()
    }
    fn __len__(&self) -> usize {
        self.log.len()
    }
    fn __repr__(&self) -> String {
        format!(
            "Log('{}', {} samples, {} joints, {} power)",
            self.log.source,
            self.log.len(),
            self.log.dof(),
            self.log.signal.name()
        )
    }
}

/// Read a user's log file (CSV or Parquet), as `identify --log` does: one `Log` per piece
/// (a log with gaps comes in pieces). `columns`: a column-map TOML or "ur-rtde"; `power`:
/// per-motor, total, bus or grid; `power_lag`: "report", "auto" or seconds.
#[pyfunction]
#[pyo3(signature = (path, columns=None, power=None, power_lag="report"))]
pub fn read_log(
    py: Python<'_>,
    path: PathBuf,
    columns: Option<String>,
    power: Option<String>,
    power_lag: &str,
) -> PyResult<Vec<PyLog>> {
    let map = columns
        .as_deref()
        .map(ColumnMap::load)
        .transpose()
        .map_err(ctx(format!(
            "loading the column map {}",
            columns.as_deref().unwrap_or_default()
        )))?;
    let opts = ReadOptions {
        power: power.as_deref().map(|p| parse("power", p)).transpose()?,
        lag: parse("power_lag", power_lag)?,
    };
    let (pieces, report) = py
        .detach(|| lib_read_log(&path, map.as_ref(), &opts))
        .map_err(ctx(format!("reading log {}", path.display())))?;
    eprintln!("{report}");
    Ok(pieces.into_iter().map(|log| PyLog { log }).collect())
}

/// The log of a twin dataset directory, as `identify --data DIR` reads it (`source`: the
/// path as given).
#[pyfunction]
pub fn read_dataset(py: Python<'_>, path: PathBuf) -> PyResult<PyLog> {
    let label = path.display().to_string();
    let log = py
        .detach(|| Dataset::read(&path).and_then(|ds| ds.log(&label)))
        .map_err(ctx(format!("reading dataset {label}")))?;
    Ok(PyLog { log })
}

/// The measured stream and summary of a dataset as a dict of numpy arrays and floats.
fn run_dict<'py>(py: Python<'py>, ds: &Dataset, label: &str) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let m = &ds.measured;
    d.set_item("t_s", PyArray1::from_slice(py, &m.t))?;
    d.set_item("q_rad", array2(py, &m.q)?)?;
    d.set_item("power_W", PyArray1::from_slice(py, &m.p_total))?;
    d.set_item("motor_power_W", array2(py, &m.p_joint)?)?;
    let s = &ds.meta.summary;
    d.set_item("duration_s", s.duration_s)?;
    d.set_item("energy_total_J", s.energy_total_j)?;
    d.set_item("energy_grid_J", s.energy_grid_j)?;
    d.set_item(
        "log",
        PyLog {
            log: ds.log(label).map_err(ctx(""))?,
        },
    )?;
    Ok(d)
}

/// Run the twin along a sampled trajectory, as `powertwin simulate` does. The trajectory is
/// `path` (a CSV, as `simulate --trajectory`) or arrays `t_s` (n,), `q_rad` (n, dof) with
/// optional `dq` and `ddq` (checked by the Python layer). Writes the dataset to `out` when
/// given; returns the measured stream.
#[pyfunction]
#[pyo3(signature = (robot, path, t_s, q_rad, dq, ddq, payload, opts, out, format))]
#[allow(clippy::too_many_arguments)]
pub fn simulate<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    path: Option<PathBuf>,
    t_s: Option<Vec<f64>>,
    q_rad: Option<PyReadonlyArray2<'py, f64>>,
    dq: Option<PyReadonlyArray2<'py, f64>>,
    ddq: Option<PyReadonlyArray2<'py, f64>>,
    payload: Vec<String>,
    opts: &Bound<'py, PyDict>,
    out: Option<PathBuf>,
    format: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = twin_options(opts)?;
    let setup = opts.setup(robot, &payload)?;
    if let Some(p) = &setup.payload {
        powertwin::model::payload::check_rated(
            p.inertia.mass,
            setup.drive.rated_payload_kg(),
            &format!("payload '{}'", p.name),
        )
        .map_err(|e| value_error(format!("{e}; pass --allow-overload to run it anyway")))?;
    }
    let format: Format = parse("format", format)?;
    let (traj, file) = match (&path, t_s, q_rad) {
        (Some(p), _, _) => {
            let table = powertwin::io::table::Table::read(p).map_err(ctx(""))?;
            let traj = Sampled::from_table(&table, robot.robot.dof()).map_err(ctx(""))?;
            (traj, p.display().to_string())
        }
        (None, Some(t), Some(q)) => {
            let traj = Sampled::new(
                t,
                columns_of(&q),
                dq.as_ref().map(columns_of),
                ddq.as_ref().map(columns_of),
            )
            .map_err(ctx("trajectory"))?;
            (traj, "<arrays>".to_string())
        }
        _ => {
            return Err(value_error(
                "simulate needs a trajectory file or t_s and q_rad",
            ));
        }
    };
    let events: Vec<PayloadEvent> = setup
        .payload
        .clone()
        .map(|p| PayloadEvent {
            t_s: 0.0,
            payload: Some(p),
        })
        .into_iter()
        .collect();
    let description = json!({"kind": "sampled", "file": file,
        "interpolation": format!("{:?}", traj.interpolation()), "start_time_s": traj.start_time()});
    let label = out
        .as_ref()
        .map_or(file.clone(), |o| o.display().to_string());
    let ds = py.detach(|| -> PyResult<Dataset> {
        let plant = setup.family.as_ref().map(|(_, p)| p);
        let (ds, _) = twin_simulate(&RunSpec {
            family: plant.map(|p| &p.draw),
            robot: plant.map_or(&robot.robot, |p| &p.robot),
            urdf: robot.urdf.clone(),
            drive: plant.map_or(&setup.drive, |p| &p.drive),
            events: &events,
            brakes: &[],
            twin: plant.map_or(&setup.twin, |p| &p.twin).clone(),
            sensor: plant.map_or(setup.sensor, |p| p.sensor),
            trajectory: &traj,
            trajectory_description: description,
            trajectory_seed: None,
        })
        .map_err(ctx(format!("simulating {file}")))?;
        if let Some(dir) = &out {
            ds.write(dir, format)
                .map_err(ctx(format!("writing {}", dir.display())))?;
        }
        Ok(ds)
    })?;
    run_dict(py, &ds, &label)
}

/// Item `j` of the global set of `powertwin dataset --seed SEED` written to
/// `OUT/item_{j:06}` (as the CLI writes it, byte for byte); `payload`: the tool (default
/// liu2018_tool). Returns the item's duration (s) and energies (J).
#[pyfunction]
#[pyo3(signature = (robot, seed, j, out, payload, opts, format))]
#[allow(clippy::too_many_arguments)]
pub fn dataset_item<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    seed: u64,
    j: usize,
    out: PathBuf,
    payload: Vec<String>,
    opts: &Bound<'py, PyDict>,
    format: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = twin_options(opts)?;
    let setup = opts.setup(robot, &payload)?;
    let tool = match setup.payload.clone() {
        Some(p) => p,
        None => crate::robot::payloads(&robot.robot, &["liu2018_tool".to_string()])?
            .ok_or_else(|| value_error("no tool"))?,
    };
    let format: Format = parse("format", format)?;
    let spec = BulkSpec {
        robot: &robot.robot,
        urdf: robot.urdf.clone(),
        drive: &setup.drive,
        tool: &tool,
        twin: setup.twin.clone(),
        sensor: setup.sensor,
        seed,
        family: setup.family.as_ref().map(|&(seed, _)| BulkFamily {
            table: powertwin::twin::family::FamilyTable::default(),
            seed,
        }),
    };
    let dir = out.join(format!("item_{j:06}"));
    let summary = py.detach(|| -> PyResult<_> {
        let (ds, _) = item(&spec, j).map_err(ctx(format!("item {j}")))?;
        ds.write(&dir, format)
            .map_err(ctx(format!("writing {}", dir.display())))?;
        Ok(ds.meta.summary)
    })?;
    let d = PyDict::new(py);
    d.set_item("item", j)?;
    d.set_item("path", dir.display().to_string())?;
    d.set_item("duration_s", summary.duration_s)?;
    d.set_item("energy_total_J", summary.energy_total_j)?;
    d.set_item("energy_grid_J", summary.energy_grid_j)?;
    Ok(d)
}

/// The twin options of the Python layer's dict (keys as `TwinOptions`' fields).
pub fn twin_options(d: &Bound<'_, PyDict>) -> PyResult<TwinOptions> {
    fn get<'py, T: FromPyObjectOwned<'py>>(d: &Bound<'py, PyDict>, key: &str) -> PyResult<T> {
        d.get_item(key)?
            .ok_or_else(|| value_error(format!("missing twin option {key}")))?
            .extract()
            .map_err(|e| value_error(format!("twin option {key}: {}", Into::<PyErr>::into(e))))
    }
    Ok(TwinOptions {
        truth: get(d, "truth")?,
        nominal_error: get(d, "nominal_error")?,
        power_signal: get(d, "power_signal")?,
        dt: get(d, "dt")?,
        substeps: get(d, "substeps")?,
        motor: get(d, "motor")?,
        sample_rate: get(d, "sample_rate")?,
        noise: get(d, "noise")?,
        power_averaging: get(d, "power_averaging")?,
        seed: get(d, "seed")?,
    })
}
