"""Bad input: Python exceptions naming the argument and what was expected, or the CLI's
message for files; nothing written half."""

import numpy as np
import pytest

import powertwin as pt
from conftest import run_cli


def test_missing_file_is_oserror_with_the_cli_message(robot, tmp_path):
    missing = tmp_path / "nope.json"
    cli = run_cli("predict", "--model", missing, "--trajectory", missing, check=False)
    assert cli.returncode == 1
    with pytest.raises(OSError) as e:
        pt.Model.load(missing, robot)
    assert str(e.value) in cli.stderr
    with pytest.raises(OSError):
        pt.read_dataset(tmp_path / "no_dataset")


def test_wrong_shapes_name_the_argument(robot):
    t = np.linspace(0, 1, 11)
    with pytest.raises(ValueError, match=r"q_rad.*\(11, 6\)"):
        pt.simulate(robot, {"t_s": t, "q_rad": np.zeros((11, 5))})
    with pytest.raises(ValueError, match=r"power_W: expected shape \(11,\)"):
        pt.log_from_arrays(t, np.zeros((11, 6)), np.zeros(10))
    with pytest.raises(ValueError, match="t_s: expected a float array"):
        pt.log_from_arrays(["a", "b"], np.zeros((2, 6)), np.zeros(2))


def test_nan_in_positions_is_named(robot):
    t = np.linspace(0, 1, 11)
    q = np.zeros((11, 6))
    q[3, 2] = np.nan
    with pytest.raises(ValueError, match=r"sample 4, joint 3 is not finite"):
        pt.simulate(robot, {"t_s": t, "q_rad": q})


def test_library_errors_are_valueerrors(robot, tmp_path):
    t = np.linspace(0, 1, 11)
    q = np.zeros((11, 6))
    q[:, 0] = np.linspace(0, 50.0, 11)  # far beyond joint 1's limit
    with pytest.raises(ValueError, match="joint limit"):
        pt.simulate(robot, {"t_s": t, "q_rad": q}, out=tmp_path / "half")
    assert not (tmp_path / "half").exists()
    with pytest.raises(ValueError, match="truth"):
        pt.simulate(robot, {"t_s": t, "q_rad": np.zeros((11, 6))}, truth="perfect")
    with pytest.raises(ValueError, match="method"):
        pt.identify(robot, [pt.log_from_arrays(t, np.zeros((11, 6)), np.zeros(11))], method="magic")


def test_predict_refuses_a_log_the_robot_cannot_have(robot, work):
    # As `powertwin predict --log` does: positions in degrees, or a megawatt glitch.
    model = pt.Model.load(work["dir"] / "cli_model.json", robot)
    t = np.linspace(0, 5, 51)
    q = np.zeros((51, 6))
    q[:, 1] = np.linspace(0.0, 40.0, 51)  # joint 2 in degrees
    with pytest.raises(ValueError, match="degrees"):
        model.predict(pt.log_from_arrays(t, q, np.full(51, 300.0)))
    p = np.full(51, 300.0)
    p[12] = 1e6
    with pytest.raises(ValueError, match="glitch"):
        model.predict(pt.log_from_arrays(t, np.zeros((51, 6)), p))
