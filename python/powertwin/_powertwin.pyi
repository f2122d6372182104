"""Type stubs of the extension module powertwin._powertwin (the Rust bindings). Units: SI
(s, rad, kg, m/s, W, J). Arrays are float64."""

from typing import Any, Optional, Sequence

import numpy as np
import numpy.typing as npt

MAX_FIT_RATE_HZ: float
DEFAULT_SUBSTEPS: int

class Robot:
    """A robot: URDF, locked joints and drive file. Picklable."""

    @staticmethod
    def irb1200(lock: Optional[Sequence[str]] = None) -> Robot: ...
    @staticmethod
    def from_urdf(path: str, drive: Optional[str] = None, lock: Optional[Sequence[str]] = None) -> Robot: ...
    @property
    def name(self) -> str: ...
    @property
    def dof(self) -> int: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def flange(self) -> str: ...

class Log:
    """A measured log: t_s (n,) s, q_rad (n, dof) rad, power_w (n,) W of kind `signal`."""

    @staticmethod
    def _from_arrays(
        t_s: npt.NDArray[np.float64],
        q_rad: npt.NDArray[np.float64],
        power_w: npt.NDArray[np.float64],
        signal: str,
        motor_power_w: Optional[npt.NDArray[np.float64]] = None,
        power_averaged: bool = False,
        source: str = "arrays",
    ) -> Log: ...
    def with_payload(self, payload: Optional[Sequence[str]]) -> Log: ...
    @property
    def source(self) -> str: ...
    @property
    def t_s(self) -> npt.NDArray[np.float64]: ...
    @property
    def q_rad(self) -> npt.NDArray[np.float64]: ...
    @property
    def power_w(self) -> npt.NDArray[np.float64]: ...
    @property
    def motor_power_w(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def signal(self) -> str: ...
    @property
    def dof(self) -> int: ...
    def __len__(self) -> int: ...

class Model:
    """An identified power model (the Rust half of powertwin.Model)."""

    @staticmethod
    def load(path: str, robot: Robot) -> Model: ...
    @staticmethod
    def _from_json(text: str, shown: str, robot: Robot) -> Model: ...
    def save(self, path: str) -> None: ...
    def to_json(self) -> str: ...
    def export_urdf(self, path: str, drive: Optional[str] = None) -> None: ...
    def _predict(
        self, log: Log, base_freq: Optional[float] = None, harmonics: int = 5, smoothing_window: Optional[int] = None
    ) -> dict[str, Any]: ...
    def _predict_trajectory(
        self,
        path: Optional[str],
        t_s: Optional[Sequence[float]],
        q_rad: Optional[npt.NDArray[np.float64]],
        dq: Optional[npt.NDArray[np.float64]],
        ddq: Optional[npt.NDArray[np.float64]],
        payload: Optional[Sequence[str]],
    ) -> dict[str, Any]: ...
    @property
    def signal(self) -> str: ...
    @property
    def theta(self) -> npt.NDArray[np.float64]: ...
    @property
    def method(self) -> Optional[str]: ...

def simulate(
    robot: Robot,
    path: Optional[str],
    t_s: Optional[Sequence[float]],
    q_rad: Optional[npt.NDArray[np.float64]],
    dq: Optional[npt.NDArray[np.float64]],
    ddq: Optional[npt.NDArray[np.float64]],
    payload: Sequence[str],
    opts: dict[str, Any],
    out: Optional[str],
    format: str,
) -> dict[str, Any]: ...
def dataset_item(
    robot: Robot, seed: int, j: int, out: str, payload: Sequence[str], opts: dict[str, Any], format: str
) -> dict[str, Any]: ...
def read_log(path: str, columns: Optional[str] = None, power: Optional[str] = None, power_lag: str = "report") -> list[Log]: ...
def read_dataset(path: str) -> Log: ...
def identify(robot: Robot, logs: Sequence[Log], args: dict[str, Any]) -> Model: ...
def holdout(robot: Robot, logs: Sequence[Log], every: Optional[int], args: dict[str, Any]) -> str: ...
def sweep(
    robot: Robot,
    model: Optional[Model],
    scenario_path: Optional[str],
    speeds: Sequence[float],
    loads: Sequence[float],
    twin: str,
    opts: dict[str, Any],
    out: Optional[str],
    format: str,
    allow_overload: bool,
) -> tuple[str, Optional[str]]: ...
def sweep_cell(
    robot: Robot,
    model: Optional[Model],
    scenario_path: Optional[str],
    speeds: Sequence[float],
    loads: Sequence[float],
    k: int,
    twin: str,
    opts: dict[str, Any],
    out: Optional[str],
    format: str,
) -> str: ...
def sweep_assemble(
    robot: Robot,
    model: Optional[Model],
    scenario_path: Optional[str],
    speeds: Sequence[float],
    loads: Sequence[float],
    twin: str,
    cells: Sequence[str],
    allow_overload: bool,
) -> tuple[str, Optional[str]]: ...
def excite_set(
    robot: Robot,
    loads: Sequence[str],
    cell: Optional[str],
    duration_s: float,
    base_freq_hz: float,
    harmonics: int,
    accel_limits: Optional[Sequence[float]],
    rounds: int,
    evals: int,
    seed: int,
    out: Optional[str],
    rate_hz: float,
) -> dict[str, Any]: ...
def validate_motion(
    robot: Robot,
    model: Model,
    k: int,
    count: int,
    seed: int,
    max_payload: Optional[float],
    opts: dict[str, Any],
    out: Optional[str],
    format: str,
) -> str: ...
def validate_assemble(seed: int, motions: Sequence[str]) -> str: ...
