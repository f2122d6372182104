"""powertwin: identify energy models of industrial robots from motor power and predict the
energy of their tasks (Python bindings of the powertwin Rust library).

Units are SI everywhere: m, rad, kg, s, N m, W, J. Arrays are float64 numpy arrays; a
trajectory or log of n samples of a robot with `dof` joints has times of shape (n,) and
positions of shape (n, dof). Tables come back as dicts of numpy arrays that
`pandas.DataFrame(...)` and `polars.DataFrame(...)` take directly.

The Rust library is the single implementation: every call below is the library call the
`powertwin` CLI makes for the same command line (the GIL released while it runs), so Python
and the CLI give the same numbers. Bad input raises ValueError, unreadable or unwritable
files OSError, with the CLI's messages.
"""

from __future__ import annotations

import json
import os
import pathlib
import warnings
from dataclasses import dataclass, field
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np

from . import _powertwin as _pt
from ._powertwin import Log, Robot

__all__ = [
    "Robot",
    "Log",
    "Model",
    "Run",
    "Prediction",
    "PlanPrediction",
    "simulate",
    "read_log",
    "read_dataset",
    "log_from_arrays",
    "identify",
    "holdout",
    "sweep",
    "excite_set",
    "dataset_item",
    "twin_options",
    "MAX_FIT_RATE_HZ",
]

PathLike = Union[str, "os.PathLike[str]"]

#: Fastest rate at which identification fits a log's states by default, Hz (the CLI's
#: `identify --fit-rate` default).
MAX_FIT_RATE_HZ: float = _pt.MAX_FIT_RATE_HZ


def _array1(name: str, x: Any, n: Optional[int] = None) -> np.ndarray:
    """`x` as a contiguous float64 vector, or ValueError naming `name` and the expected shape."""
    try:
        a = np.ascontiguousarray(np.asarray(x, dtype=np.float64))
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: expected a float array of shape (n,), got {type(x).__name__} ({e})") from None
    if a.ndim != 1:
        raise ValueError(f"{name}: expected shape (n,), got {a.shape}")
    if n is not None and a.shape[0] != n:
        raise ValueError(f"{name}: expected shape ({n},) (one value per sample), got {a.shape}")
    if not np.all(np.isfinite(a)):
        k = int(np.flatnonzero(~np.isfinite(a))[0])
        raise ValueError(f"{name}: sample {k + 1} is not finite ({a[k]})")
    return a


def _array2(name: str, x: Any, n: Optional[int], cols: int, unit: str) -> np.ndarray:
    """`x` as a contiguous float64 (n, cols) array, or ValueError naming `name`, the shape and
    the unit."""
    try:
        a = np.ascontiguousarray(np.asarray(x, dtype=np.float64))
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: expected a float array of shape (n, {cols}) in {unit} ({e})") from None
    if a.ndim != 2 or a.shape[1] != cols or (n is not None and a.shape[0] != n):
        want = f"({n if n is not None else 'n'}, {cols})"
        raise ValueError(f"{name}: expected shape {want} in {unit} (one row per sample, one column per joint), got {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        k, j = (int(v) for v in np.argwhere(bad)[0])
        raise ValueError(f"{name}: sample {k + 1}, joint {j + 1} is not finite ({a[k, j]})")
    return a


def _payload_list(payload: Union[None, str, Sequence[str]]) -> list:
    if payload is None:
        return []
    if isinstance(payload, (str, os.PathLike)):
        return [os.fspath(payload)]
    return [os.fspath(p) for p in payload]


def twin_options(
    *,
    truth: str = "realistic",
    seed: int = 0,
    nominal_error: Optional[float] = None,
    power_signal: Optional[str] = None,
    dt: float = 0.001,
    substeps: Optional[int] = None,
    motor: str = "pmsm",
    sample_rate: float = 10.0,
    noise: Optional[str] = None,
    power_averaging: bool = False,
) -> dict:
    """The twin settings of a run, with the CLI's defaults (`--truth`: "realistic", "exact"
    or "family:SEED" (a robot of the family of truths, the built-in table), `--noise-seed`,
    `--nominal-error`, `--power-signal`, `--dt` (s), `--substeps`, `--motor`,
    `--sample-rate` (Hz), `--noise` (a TOML path or "none"), `--power-averaging`); `substeps`
    None: the library's default, as the CLI's."""
    return {
        "truth": truth,
        "seed": int(seed),
        "nominal_error": nominal_error,
        "power_signal": power_signal,
        "dt": float(dt),
        "substeps": int(_pt.DEFAULT_SUBSTEPS if substeps is None else substeps),
        "motor": motor,
        "sample_rate": float(sample_rate),
        "noise": None if noise is None else os.fspath(noise),
        "power_averaging": bool(power_averaging),
    }


def _trajectory(robot: Robot, trajectory: Any):
    """(path, t, q, dq, ddq) of a trajectory given as a CSV path or a mapping of arrays
    `t_s` (n,), `q_rad` (n, dof), optional `dq_rad_s`, `ddq_rad_s2` (n, dof)."""
    if isinstance(trajectory, (str, os.PathLike)):
        return os.fspath(trajectory), None, None, None, None
    if not isinstance(trajectory, Mapping):
        raise ValueError("trajectory: expected a CSV path or a mapping with t_s (n,) and q_rad (n, dof)")
    if "t_s" not in trajectory or "q_rad" not in trajectory:
        raise ValueError("trajectory: needs t_s (s, shape (n,)) and q_rad (rad, shape (n, dof))")
    t = _array1("trajectory['t_s']", trajectory["t_s"])
    q = _array2("trajectory['q_rad']", trajectory["q_rad"], t.shape[0], robot.dof, "rad")
    dq = trajectory.get("dq_rad_s")
    ddq = trajectory.get("ddq_rad_s2")
    dq = None if dq is None else _array2("trajectory['dq_rad_s']", dq, t.shape[0], robot.dof, "rad/s")
    ddq = None if ddq is None else _array2("trajectory['ddq_rad_s2']", ddq, t.shape[0], robot.dof, "rad/s^2")
    return None, t.tolist(), q, dq, ddq


def simulate(
    robot: Robot,
    trajectory: Any,
    *,
    payload: Union[None, str, Sequence[str]] = None,
    out: Optional[PathLike] = None,
    format: str = "parquet",
    **twin: Any,
) -> dict:
    """Run the twin along a trajectory, as `powertwin simulate` does.

    `trajectory`: a CSV path (t_s in s, q1_rad.. in rad, optionally dq*_rad_s, ddq*_rad_s2) or
    a mapping with arrays `t_s` (n,), `q_rad` (n, dof) and optionally `dq_rad_s`, `ddq_rad_s2`.
    `payload`: built-in payload names or payload TOML files at the flange throughout. `twin`:
    the options of `twin_options` (truth="realistic", seed=0, sample_rate=10.0 Hz, ...). With
    `out`, the dataset is written there (as `simulate --out`).

    Returns a dict: t_s (n,) s, q_rad (n, dof) rad, power_W (n,) W (the logged signal),
    motor_power_W (n, dof) W, duration_s, energy_total_J and energy_grid_J (the twin's truth),
    and `log`: the run as a `Log` for `identify` and `Model.predict`.
    """
    path, t, q, dq, ddq = _trajectory(robot, trajectory)
    return _pt.simulate(
        robot, path, t, q, dq, ddq, _payload_list(payload), twin_options(**twin),
        None if out is None else os.fspath(out), format,
    )


def dataset_item(
    robot: Robot,
    j: int,
    out: PathLike,
    *,
    seed: int = 0,
    payload: Union[None, str, Sequence[str]] = None,
    format: str = "parquet",
    **twin: Any,
) -> dict:
    """Write item `j` of `powertwin dataset --seed SEED` to `out/item_{j:06d}` (byte for byte
    what the CLI writes with the same twin options). Returns the item's duration_s and
    energies (J)."""
    if "seed" in twin:
        raise ValueError("dataset_item: the noise seed is drawn per item; pass the set's seed as seed=")
    return _pt.dataset_item(
        robot, int(seed), int(j), os.fspath(out), _payload_list(payload), twin_options(**twin), format
    )


def read_log(
    path: PathLike,
    *,
    columns: Optional[str] = None,
    power: Optional[str] = None,
    power_lag: Union[str, float] = "report",
    pieces: bool = False,
) -> Union[Log, list]:
    """Read a measured log (CSV or Parquet), as `identify --log` does. `columns`: a column-map
    TOML or "ur-rtde"; `power`: per-motor, total, bus or grid; `power_lag`: "report", "auto"
    or a lag in s. A log with gaps comes in pieces: with `pieces=True` the list of them, else
    the one `Log` (ValueError when there are several)."""
    logs = _pt.read_log(os.fspath(path), columns, power, str(power_lag))
    if pieces:
        return logs
    if len(logs) != 1:
        raise ValueError(f"{os.fspath(path)}: the log comes in {len(logs)} pieces; pass pieces=True")
    return logs[0]


def read_dataset(path: PathLike) -> Log:
    """The log of a twin dataset directory (what `identify --data DIR` reads)."""
    return _pt.read_dataset(os.fspath(path))


def log_from_arrays(
    t_s: Any,
    q_rad: Any,
    power_W: Any,
    *,
    signal: str = "total",
    motor_power_W: Any = None,
    power_averaged: bool = False,
    source: str = "arrays",
) -> Log:
    """A log from arrays: `t_s` (n,) s strictly increasing, `q_rad` (n, dof) rad, `power_W`
    (n,) W of kind `signal` ("total", "bus" or "grid"), `motor_power_W` (n, dof) W or None.
    A DataFrame's columns can be passed as arrays (`df["t_s"].to_numpy()`)."""
    t = _array1("t_s", t_s)
    q = np.asarray(q_rad, dtype=np.float64)
    dof = q.shape[1] if q.ndim == 2 else -1
    if dof < 1:
        raise ValueError(f"q_rad: expected shape (n, dof) in rad, got {q.shape}")
    q = _array2("q_rad", q, t.shape[0], dof, "rad")
    p = _array1("power_W", power_W, t.shape[0])
    m = None if motor_power_W is None else _array2("motor_power_W", motor_power_W, t.shape[0], dof, "W")
    return Log._from_arrays(t, q, p, signal, m, bool(power_averaged), source)


@dataclass
class Run:
    """A log and the payload the user knows it carried (built-in names or payload TOML files,
    at the flange throughout; None: no payload)."""

    log: Log
    payload: Union[None, str, Sequence[str]] = None

    def resolved(self) -> Log:
        return self.log.with_payload(_payload_list(self.payload) or None)


@dataclass
class Prediction:
    """The predicted energy of a logged motion (`powertwin predict`): `energy_J` and its 95 %
    interval half width `interval_J` (J), the measured energy `measured_J`, and the power at
    the logged samples: `t_s` (s), `power_W` (predicted), `measured_W` (W). `below_seen_J` and
    `unseen_load_J` (J) are the parts of the motion the identification logs never showed (a
    clipped meter below its lowest seen level; a payload heavier than they carried), as
    `predict --json` gives them; `alternative_J` (J, None without one) what the model of the
    other friction law (with load-dependent gear friction if this one has none, without it if
    it has) predicts (`energy_J` is the mean of the model's own and this); `stribeck_J` (J, None without a Stribeck law) what it predicts with the
    whole of the drive file's Stribeck rise at slow joint speeds (the model takes part of it).
    The interval includes them. `rest_s` (s) is the time the motion rests (every joint slower
    than the least speed the identification fitted): the interval takes the error a left-out
    identification log's pieces share in proportion to it."""

    energy_J: float
    interval_J: float
    duration_s: float
    below_seen_J: float
    unseen_load_J: float
    alternative_J: Optional[float]
    stribeck_J: Optional[float]
    rest_s: float
    measured_J: float
    error_pct: float
    power_rmse_W: float
    t_s: np.ndarray
    power_W: np.ndarray
    measured_W: np.ndarray


@dataclass
class PlanPrediction:
    """The predicted energy of a planned motion (`powertwin predict --trajectory`):
    `energy_J` with its 95 % interval half width `interval_J` (J), `duration_s`,
    `mean_power_W`, and the power `power_W` (W) at the plan's sample times `t_s` (s);
    `below_seen_J`, `unseen_load_J`, `alternative_J`, `stribeck_J` (J) and `rest_s` (s) as in
    `Prediction`."""

    energy_J: float
    interval_J: float
    duration_s: float
    below_seen_J: float
    unseen_load_J: float
    alternative_J: Optional[float]
    stribeck_J: Optional[float]
    rest_s: float
    mean_power_W: float
    t_s: np.ndarray
    power_W: np.ndarray


class Model:
    """An identified power model (base parameters, motor losses, covariance) of a robot.

    From `identify(...)` or `Model.load(path, robot)`; picklable (for Dask)."""

    def __init__(self, inner: "_pt.Model", robot: Robot):
        self._m = inner
        self.robot = robot

    @staticmethod
    def load(path: PathLike, robot: Robot) -> "Model":
        """Read a model file written by `identify` (`powertwin identify --out` or
        `Model.save`) for `robot`."""
        return Model(_pt.Model.load(os.fspath(path), robot), robot)

    def save(self, path: PathLike) -> None:
        """Write the model file (JSON), what `powertwin identify --out` writes."""
        self._m.save(os.fspath(path))

    def to_json(self) -> str:
        """The model file's JSON text."""
        return self._m.to_json()

    def export_urdf(self, path: PathLike, drive: Optional[PathLike] = None) -> None:
        """Write the identified robot as URDF (physically consistent inertials and friction),
        and with `drive` its drive file (TOML), as `identify --export-urdf --export-drive`."""
        self._m.export_urdf(os.fspath(path), None if drive is None else os.fspath(drive))

    @property
    def signal(self) -> str:
        """The modelled power signal: "total", "bus" or "grid"."""
        return self._m.signal

    @property
    def theta(self) -> np.ndarray:
        """The identified base parameters (model units), shape (p,)."""
        return self._m.theta

    def predict(
        self,
        log: Union[Log, Run],
        *,
        base_freq: Optional[float] = None,
        harmonics: int = 5,
        smoothing_window: Optional[int] = None,
    ) -> Prediction:
        """The energy of a logged motion with its 95 % interval, as `powertwin predict`
        (`base_freq` Hz, `harmonics`, `smoothing_window` samples: the CLI's route options)."""
        if isinstance(log, Run):
            log = log.resolved()
        if not isinstance(log, Log):
            raise ValueError(f"log: expected a powertwin.Log or Run, got {type(log).__name__}")
        return Prediction(**self._m._predict(log, base_freq, harmonics, smoothing_window))

    def predict_trajectory(
        self,
        t_s: Any,
        q_rad: Any = None,
        *,
        dq_rad_s: Any = None,
        ddq_rad_s2: Any = None,
        payload: Union[None, str, Sequence[str]] = None,
    ) -> PlanPrediction:
        """The energy and power of a planned motion nobody has run, as `powertwin predict
        --trajectory`: `t_s` (n,) s and `q_rad` (n, dof) rad (optionally `dq_rad_s`,
        `ddq_rad_s2`), or `t_s` a plan CSV path; `payload` at the flange from the start."""
        if q_rad is None and isinstance(t_s, (str, os.PathLike)):
            args = (os.fspath(t_s), None, None, None, None)
        else:
            traj = {"t_s": t_s, "q_rad": q_rad}
            if dq_rad_s is not None:
                traj["dq_rad_s"] = dq_rad_s
            if ddq_rad_s2 is not None:
                traj["ddq_rad_s2"] = ddq_rad_s2
            args = _trajectory(self.robot, traj)
        return PlanPrediction(**self._m._predict_trajectory(*args, _payload_list(payload) or None))

    def __reduce__(self):
        return (_model_from_json, (self.to_json(), self.robot))

    def __repr__(self) -> str:
        return repr(self._m)


def _model_from_json(text: str, robot: Robot) -> Model:
    return Model(_pt.Model._from_json(text, "pickled model", robot), robot)


def identify(
    robot: Robot,
    runs: Sequence[Union[Log, Run]],
    *,
    method: str = "auto",
    base_freq: Optional[float] = None,
    harmonics: int = 5,
    smoothing_window: Optional[int] = None,
    min_speed: Optional[float] = None,
    fit_rate: float = MAX_FIT_RATE_HZ,
    weighting: Optional[str] = None,
    unconstrained: bool = False,
    arm_power_only: bool = False,
    prior: bool = True,
    prior_widths: Optional[Mapping[str, float]] = None,
) -> Model:
    """Identify a power model from logs, as `powertwin identify` does with `--method auto`
    (or "total", "pmsm", "gear": load-dependent gear friction where cross-validation prefers
    it to "pmsm"): the estimator chosen by cross-validation, the model physically consistent,
    the prior from the URDF and the robot's drive file. `runs`: Logs, or Runs with their
    known payloads. `min_speed` rad/s (default 0.05), `fit_rate` Hz, `weighting` "none" |
    "per-log" | "power-level", `prior_widths` {mass, com (m), inertia, friction, rotor,
    copper, gear}: the CLI's options. (The CLI's held-out check, `--holdout`, is `holdout`: it
    does not change the model.)"""
    args = _fit_args(
        method, base_freq, harmonics, smoothing_window, min_speed, fit_rate, weighting,
        unconstrained, arm_power_only, prior, prior_widths,
    )
    return Model(_pt.identify(robot, _logs_of(runs), args), robot)


def holdout(
    robot: Robot,
    runs: Sequence[Union[Log, Run]],
    *,
    every: Optional[int] = None,
    method: str = "auto",
    base_freq: Optional[float] = None,
    harmonics: int = 5,
    smoothing_window: Optional[int] = None,
    min_speed: Optional[float] = None,
    fit_rate: float = MAX_FIT_RATE_HZ,
    weighting: Optional[str] = None,
    unconstrained: bool = False,
    arm_power_only: bool = False,
    prior: bool = True,
    prior_widths: Optional[Mapping[str, float]] = None,
) -> dict:
    """Is my model good? Check `identify` out of sample on your own logs, as `powertwin identify
    --holdout K` does before fitting on everything: leave out every K-th run (with fewer than 4
    runs, every K-th rest-to-rest move; with `base_freq`, always runs), identify on the rest
    with the same options as `identify` and predict each piece left out. `every`: K (None: the
    CLI's default, 4, or 3 where there are only three pieces). Returns the CLI's `identify
    --json` "holdout": `every`, `unit` ("run" | "move"), `trained_on`, `pieces` (each with
    `source`, `measured_J`, `predicted_J`, `interval_95_J`, `error_pct`, `covered`,
    `power_rmse_W`), `median_abs_error_pct`, `worst_abs_error_pct`, `coverage` (0-1) and
    `median_power_rmse_W`. Raises ValueError where there are too few pieces to leave one out."""
    args = _fit_args(
        method, base_freq, harmonics, smoothing_window, min_speed, fit_rate, weighting,
        unconstrained, arm_power_only, prior, prior_widths,
    )
    every = None if every is None else int(every)
    return json.loads(_pt.holdout(robot, _logs_of(runs), every, args))


def _fit_args(method, base_freq, harmonics, smoothing_window, min_speed, fit_rate, weighting,
              unconstrained, arm_power_only, prior, prior_widths) -> dict:
    """`identify`'s and `holdout`'s options as the bindings take them."""
    return {
        "method": method,
        "base_freq": base_freq,
        "harmonics": int(harmonics),
        "smoothing_window": smoothing_window,
        "min_speed": min_speed,
        "fit_rate": float(fit_rate),
        "weighting": weighting,
        "unconstrained": bool(unconstrained),
        "arm_power_only": bool(arm_power_only),
        "prior": bool(prior),
        "prior_widths": None if prior_widths is None else dict(prior_widths),
    }


def _logs_of(runs: Sequence[Union[Log, Run]]) -> list:
    """The logs of `runs` (Logs, or Runs resolved with their payloads); ValueError for anything
    else or none."""
    logs = []
    for k, r in enumerate(runs):
        if isinstance(r, Run):
            logs.append(r.resolved())
        elif isinstance(r, Log):
            logs.append(r)
        else:
            raise ValueError(f"runs[{k}]: expected a powertwin.Log or Run, got {type(r).__name__}")
    if not logs:
        raise ValueError("runs: no log given")
    return logs


def excite_set(
    robot: Robot,
    n: int,
    *,
    loads: Optional[Sequence[Union[None, str, Sequence[str]]]] = None,
    cell: Optional[PathLike] = None,
    duration_s: float = 30.0,
    base_freq_hz: float = 0.1,
    harmonics: int = 5,
    accel_limits: Optional[Sequence[float]] = None,
    rounds: int = 2,
    evals: int = 2000,
    seed: int = 1,
    out: Optional[PathLike] = None,
    rate_hz: float = 100.0,
) -> dict:
    """Design `n` excitations together for identification, as `powertwin excite --set N`:
    `loads` one payload per excitation (None, a built-in name or payload file, or a list of
    them combined) or one for all; `cell` a cell TOML; `duration_s` s; `base_freq_hz` Hz;
    `accel_limits` rad/s^2 per joint; `rounds`, `evals` (the CLI's `--evals`, default 2000)
    and `seed` of the design. With `out`, the set's CSV files and runs manifest are written
    there at `rate_hz` Hz, as the CLI writes them. Returns `trajectories` (dicts t_s, q_rad,
    dq_rad_s, ddq_rad_s2 sampled at `rate_hz`, usable by `simulate`), `cond_initial`,
    `cond_final` and `member_conds` (condition numbers)."""
    n = int(n)
    if n < 1:
        raise ValueError(f"n: at least 1 excitation, got {n}")
    specs = ["none" if p is None else "+".join(_payload_list(p)) for p in (loads or [])]
    if len(specs) == 0:
        specs = ["none"] * n
    elif len(specs) == 1:
        specs = specs * n
    elif len(specs) != n:
        raise ValueError(f"loads: {len(specs)} entries for {n} excitations: give one per excitation or one for all")
    limits = None if accel_limits is None else _array1("accel_limits", accel_limits, robot.dof).tolist()
    return _pt.excite_set(
        robot, specs, None if cell is None else os.fspath(cell), float(duration_s), float(base_freq_hz),
        int(harmonics), limits, int(rounds), int(evals), int(seed),
        None if out is None else os.fspath(out), float(rate_hz),
    )


def _floats(name: str, xs: Optional[Sequence[float]]) -> list:
    if xs is None:
        return []
    a = _array1(name, xs)
    return a.tolist()


def sweep(
    robot: Robot,
    model: Optional[Model] = None,
    *,
    scenario: Optional[PathLike] = None,
    speeds: Optional[Sequence[float]] = None,
    loads: Optional[Sequence[float]] = None,
    twin: str = "urdf",
    out: Optional[PathLike] = None,
    format: str = "parquet",
    allow_overload: bool = False,
    **twin_settings: Any,
) -> dict:
    """Run a task scenario over TCP speeds (m/s) and load levels (kg) on the twin, as
    `powertwin sweep` does (`twin`: "urdf", "identified" or "none"; the last two need
    `model`). Returns sweep.json as a dict (what `sweep --json` prints) with `table`: the
    cells as a dict of numpy arrays (speed_m_s, load_kg, cycle_time_s, simulated_J, ...).
    Flagged cells (torque saturated, tracking lost) raise a RuntimeWarning unless
    `allow_overload`. With `out`, writes the datasets, sweep.json and the chart there."""
    inner = None if model is None else model._m
    text, flagged = _pt.sweep(
        robot, inner, None if scenario is None else os.fspath(scenario),
        _floats("speeds", speeds), _floats("loads", loads), twin, twin_options(**twin_settings),
        None if out is None else os.fspath(out), format, bool(allow_overload),
    )
    if flagged:
        warnings.warn(flagged, RuntimeWarning, stacklevel=2)
    doc = json.loads(text)
    doc["table"] = cells_table(doc["cells"])
    return doc


def _write_text_atomic(path: pathlib.Path, text: str) -> None:
    """Write `text` to `path` through a temporary sibling renamed into place."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, path)


def cells_table(cells: Sequence[Mapping[str, Any]]) -> dict:
    """The scalar columns of sweep cells as a dict of numpy arrays (None as NaN)."""
    if not cells:
        return {}
    cols = [k for k, v in cells[0].items() if v is None or isinstance(v, (int, float, bool))]
    out = {}
    for k in cols:
        vals = [c.get(k) for c in cells]
        if all(isinstance(v, bool) for v in vals):
            out[k] = np.array(vals, dtype=bool)
        else:
            out[k] = np.array([np.nan if v is None else v for v in vals], dtype=np.float64)
    return out
