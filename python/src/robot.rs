//! `Robot` and the twin settings of a run (what the CLI's `--robot`, `--drive`, `--lock` and
//! twin options give).

use std::path::{Path, PathBuf};

use powertwin::Robot;
use powertwin::dataset::meta::Urdf;
use powertwin::model::builtin;
use powertwin::model::drive::Drive;
use powertwin::model::payload::Payload;
use powertwin::model::urdf::{LoadOptions, load_str};
use powertwin::twin::TwinConfig;
use powertwin::twin::family::{FamilyTable, Plant};
use powertwin::twin::physics::PhysicsSettings;
use powertwin::twin::sensor::{NoiseSettings, SensorSettings};
use pyo3::prelude::*;

use crate::{ctx, parse, value_error};

/// A robot: its URDF, the joints locked at 0 and its drive file (rotor inertia, friction,
/// efficiency, losses).
///
/// Built with `Robot.irb1200()` (the built-in ABB IRB 1200-7/0.7 and its drive) or
/// `Robot.from_urdf(path, drive=None, lock=None)`. Picklable (the URDF and drive texts travel
/// with it), so it can be sent to Dask workers.
#[pyclass(name = "Robot", module = "powertwin._powertwin", frozen)]
pub struct PyRobot {
    pub robot: Robot,
    /// The URDF as a dataset records it.
    pub urdf: Urdf,
    /// URDF path as given (`None`: built in) and its text.
    urdf_path: Option<String>,
    urdf_text: String,
    /// Drive file path as given and its text (`None`: the built-in drive for the built-in
    /// robot, else none).
    drive_file: Option<(String, String)>,
    lock: Vec<String>,
}

impl PyRobot {
    /// Build from texts (the constructor and the unpickler).
    fn build(
        urdf: Option<(String, String)>,
        drive_file: Option<(String, String)>,
        lock: Vec<String>,
    ) -> PyResult<PyRobot> {
        let opts = LoadOptions { lock: lock.clone() };
        let (robot, meta, urdf_path, urdf_text) = match urdf {
            None => (
                load_str(builtin::IRB1200_URDF, &opts)
                    .map_err(ctx("loading the built-in IRB 1200 model"))?,
                Urdf::inline(builtin::IRB1200_URDF),
                None,
                builtin::IRB1200_URDF.to_string(),
            ),
            Some((path, text)) => (
                load_str(&text, &opts).map_err(ctx(format!("loading robot {path}")))?,
                Urdf::file(&path, &text),
                Some(path),
                text,
            ),
        };
        let out = PyRobot {
            robot,
            urdf: meta,
            urdf_path,
            urdf_text,
            drive_file,
            lock,
        };
        out.drive()?;
        Ok(out)
    }

    /// The drive file given, or the built-in IRB 1200 drive for the built-in robot, `None`
    /// for another robot without a drive file (as the CLI's `--drive`).
    pub fn drive(&self) -> PyResult<Option<Drive>> {
        match (&self.drive_file, &self.urdf_path) {
            (Some((path, text)), _) => Drive::from_toml_str(text, path, &self.robot)
                .map(Some)
                .map_err(ctx(format!("loading drive {path}"))),
            (None, None) => Drive::from_toml_str(
                builtin::IRB1200_DRIVE,
                "built-in irb1200_7_70.drive.toml",
                &self.robot,
            )
            .map(Some)
            .map_err(ctx("")),
            (None, Some(_)) => Ok(None),
        }
    }

    /// The drives of the twin: the drive file's, or the URDF's friction with ideal motors.
    pub fn twin_drive(&self) -> PyResult<Drive> {
        Ok(self
            .drive()?
            .unwrap_or_else(|| Drive::from_urdf(&self.robot)))
    }
}

fn read_text(path: &Path, what: &str) -> PyResult<String> {
    std::fs::read_to_string(path).map_err(|e| {
        pyo3::exceptions::PyOSError::new_err(format!("loading {what} {}: {e}", path.display()))
    })
}

#[pymethods]
impl PyRobot {
    /// The built-in ABB IRB 1200-7/0.7 with its drive file; `lock`: joint names frozen at 0.
    #[staticmethod]
    #[pyo3(signature = (lock=None))]
    fn irb1200(lock: Option<Vec<String>>) -> PyResult<PyRobot> {
        PyRobot::build(None, None, lock.unwrap_or_default())
    }

    /// A fixed-base serial robot with revolute joints from its URDF `path`; `drive`: its drive
    /// file (TOML; without it the URDF's friction and ideal motors); `lock`: joint names frozen
    /// at 0. Raises OSError for unreadable files, ValueError for an unsupported model.
    #[staticmethod]
    #[pyo3(signature = (path, drive=None, lock=None))]
    fn from_urdf(
        path: PathBuf,
        drive: Option<PathBuf>,
        lock: Option<Vec<String>>,
    ) -> PyResult<PyRobot> {
        let urdf = (path.display().to_string(), read_text(&path, "robot")?);
        let drive = match drive {
            Some(p) => Some((p.display().to_string(), read_text(&p, "drive")?)),
            None => None,
        };
        PyRobot::build(Some(urdf), drive, lock.unwrap_or_default())
    }

    /// Unpickle (private).
    #[staticmethod]
    fn _from_state(
        urdf: Option<(String, String)>,
        drive: Option<(String, String)>,
        lock: Vec<String>,
    ) -> PyResult<PyRobot> {
        PyRobot::build(urdf, drive, lock)
    }

    fn __reduce__(slf: &Bound<'_, Self>) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
        let py = slf.py();
        let this = slf.get();
        let ctor = py.get_type::<PyRobot>().getattr("_from_state")?.unbind();
        let urdf = this.urdf_path.clone().map(|p| (p, this.urdf_text.clone()));
        let args = (urdf, this.drive_file.clone(), this.lock.clone())
            .into_pyobject(py)?
            .into_any()
            .unbind();
        Ok((ctor, args))
    }

    /// Robot name (the URDF's).
    #[getter]
    fn name(&self) -> String {
        self.robot.name().to_string()
    }

    /// Number of moving joints.
    #[getter]
    fn dof(&self) -> usize {
        self.robot.dof()
    }

    /// Names of the moving joints, base to flange.
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.robot.joints().iter().map(|j| j.name.clone()).collect()
    }

    /// Name of the flange link (where payloads attach).
    #[getter]
    fn flange(&self) -> String {
        self.robot.flange_name().to_string()
    }

    fn __repr__(&self) -> String {
        format!("Robot('{}', dof={})", self.robot.name(), self.robot.dof())
    }
}

/// Twin settings of a run, as the CLI's twin options (`--truth`, `--dt`, ...).
#[derive(Clone)]
pub struct TwinOptions {
    pub truth: String,
    pub nominal_error: Option<f64>,
    pub power_signal: Option<String>,
    pub dt: f64,
    pub substeps: usize,
    pub motor: String,
    pub sample_rate: f64,
    pub noise: Option<String>,
    pub power_averaging: bool,
    pub seed: u64,
}

/// What a twin run needs besides the trajectory (the CLI's `Setup`).
pub struct Setup {
    pub drive: Drive,
    pub payload: Option<Payload>,
    pub twin: TwinConfig,
    pub sensor: SensorSettings,
    /// The family seed of `truth="family:SEED"`, and the robot it draws (the built-in table).
    pub family: Option<(u64, Plant)>,
}

/// The payloads of the CLI's repeated `--payload NAME|PATH`, combined (a path that exists is
/// a payload file, else a built-in name).
pub fn payloads(robot: &Robot, specs: &[String]) -> PyResult<Option<Payload>> {
    let mut payload: Option<Payload> = None;
    for p in specs {
        let one = if Path::new(p).exists() {
            Payload::from_file(Path::new(p)).map_err(ctx(""))?
        } else {
            if let Some(w) = builtin::foreign_payload_warning(p, robot.name()) {
                eprintln!("warning: {w}");
            }
            builtin::payload(p).map_err(ctx(""))?
        };
        payload = Some(match payload {
            Some(acc) => acc.combined(&one),
            None => one,
        });
    }
    Ok(payload)
}

impl TwinOptions {
    /// Load and validate everything, as the CLI's `TwinArgs::setup`.
    pub fn setup(&self, robot: &PyRobot, payload: &[String]) -> PyResult<Setup> {
        use powertwin::measurement::PowerSignal;
        use powertwin::twin::Fidelity;
        let drive = robot.twin_drive()?;
        let payload = payloads(&robot.robot, payload)?;
        let noise = match self.noise.as_deref() {
            None => NoiseSettings::default(),
            Some("none") => NoiseSettings::NONE,
            Some(path) => {
                let text = read_text(Path::new(path), "noise")?;
                NoiseSettings::from_toml_str(&text, path).map_err(ctx(""))?
            }
        };
        // `family:SEED`: a realistic robot of the family, drawn below around the files.
        let family_seed = match self.truth.strip_prefix("family:") {
            Some(seed) => Some(seed.trim().parse::<u64>().map_err(|_| {
                value_error(format!(
                    "truth '{}': the family seed must be a whole number >= 0 (family:SEED)",
                    self.truth
                ))
            })?),
            None => None,
        };
        let fidelity: Fidelity = match family_seed {
            Some(_) => Fidelity::Realistic,
            None => parse("truth", &self.truth)?,
        };
        let realistic = matches!(fidelity, Fidelity::Realistic);
        let signal: PowerSignal = match &self.power_signal {
            Some(s) => parse("power_signal", s)?,
            None if realistic => PowerSignal::Bus,
            None => PowerSignal::Total,
        };
        let twin = TwinConfig {
            physics: PhysicsSettings {
                dt: self.dt,
                substeps: self.substeps,
            },
            motor: parse("motor", &self.motor)?,
            nominal_error: self
                .nominal_error
                .unwrap_or(if realistic { 0.1 } else { 0.0 }),
            nominal_seed: self.seed,
            fidelity,
            ..TwinConfig::default()
        };
        twin.physics.validate().map_err(ctx(""))?;
        let sensor = SensorSettings {
            rate_hz: self.sample_rate,
            power_averaging: self.power_averaging,
            power_signal: signal,
            noise,
            seed: self.seed,
            ..SensorSettings::default()
        };
        let family = match family_seed {
            Some(seed) => {
                let mut plant = FamilyTable::default()
                    .draw(&robot.robot, &drive, &twin, &sensor, seed)
                    .map_err(ctx(""))?;
                if let Some(e) = self.nominal_error {
                    plant.twin.nominal_error = e;
                    plant.draw.nominal_error = e;
                }
                Some((seed, plant))
            }
            None => None,
        };
        Ok(Setup {
            drive,
            payload,
            twin,
            sensor,
            family,
        })
    }
}
