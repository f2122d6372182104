"""The bindings give the CLI's numbers to the last digit (and its files byte for byte)."""

import json
import pickle

import numpy as np
import pytest

import powertwin as pt
from conftest import run_cli


def files(d):
    return {p.name: p.read_bytes() for p in sorted(d.iterdir())}


def test_simulate_writes_the_cli_dataset(robot, work):
    d = work["dir"]
    run = pt.simulate(robot, work["plans"][0], seed=1, out=d / "py_run0")
    assert files(d / "py_run0") == files(d / "cli_run0")
    log = pt.read_dataset(d / "cli_run0")
    assert np.array_equal(run["t_s"], log.t_s)
    assert np.array_equal(run["q_rad"], log.q_rad)
    assert run["q_rad"].shape == (len(log), robot.dof)
    meta = json.loads((d / "cli_run0" / "meta.json").read_text())
    assert run["energy_total_J"] == meta["summary"]["energy_total_J"]


def test_simulate_from_arrays_equals_the_csv(robot, work):
    plan = work["plans"][1]
    table = np.loadtxt(plan, delimiter=",", skiprows=1)
    a = pt.simulate(robot, {"t_s": table[:, 0], "q_rad": table[:, 1:]}, seed=2)
    b = pt.simulate(robot, plan, seed=2)
    assert np.array_equal(a["power_W"], b["power_W"])
    assert a["energy_grid_J"] == b["energy_grid_J"]


def test_identify_saves_the_cli_model_file(robot, work):
    d = work["dir"]
    model = pt.identify(robot, [pt.read_dataset(d / "cli_run0")])
    model.save(d / "py_model.json")
    assert (d / "py_model.json").read_bytes() == (d / "cli_model.json").read_bytes()
    model.export_urdf(d / "py_identified.urdf")
    assert (d / "py_identified.urdf").read_bytes() == (d / "cli_identified.urdf").read_bytes()


def test_holdout_equals_cli(robot, work, tmp_path):
    """`holdout` is `identify --holdout K`'s check: the same pieces, predictions and figures."""
    d = work["dir"]
    runs = [d / "cli_run0", d / "cli_run1"]
    cli = json.loads(run_cli("identify", "--data", *runs, "--holdout", "2", "--json",
                             "--out", tmp_path / "m.json").stdout)["holdout"]
    py = pt.holdout(robot, [pt.read_dataset(r) for r in runs], every=2)
    assert py == cli
    assert py["unit"] == "move" and len(py["pieces"]) == 1
    # Two pieces are too few for the default K: an error, not a silent skip.
    with pytest.raises(ValueError, match="too few pieces"):
        pt.holdout(robot, [pt.read_dataset(r) for r in runs])


def test_predict_equals_cli(robot, work):
    d = work["dir"]
    model = pt.Model.load(d / "cli_model.json", robot)
    cli = json.loads(run_cli("predict", "--model", d / "cli_model.json", "--data", d / "cli_run1", "--json").stdout)
    pred = model.predict(pt.read_dataset(d / "cli_run1"))
    assert pred.energy_J == cli["predicted_J"]
    assert pred.interval_J == cli["interval_95_J"]
    assert (pred.below_seen_J, pred.unseen_load_J) == (cli["below_seen_J"], cli["unseen_load_J"])
    assert pred.alternative_J == cli["alternative_J"]
    assert pred.stribeck_J == cli["stribeck_J"]
    assert pred.rest_s == cli["rest_s"]
    assert pred.measured_J == cli["measured_J"]
    assert pred.power_rmse_W == cli["power_rmse_W"]
    assert pred.power_W.shape == pred.t_s.shape == pred.measured_W.shape


def test_predict_trajectory_equals_cli(robot, work):
    d, plan = work["dir"], work["plans"][1]
    model = pt.Model.load(d / "cli_model.json", robot)
    for payload in (None, "liu2018_load_2kg"):
        args = ["--payload", payload] if payload else []
        cli = json.loads(run_cli("predict", "--model", d / "cli_model.json", "--trajectory", plan, "--json", *args).stdout)
        table = np.loadtxt(plan, delimiter=",", skiprows=1)
        from_arrays = model.predict_trajectory(table[:, 0], table[:, 1:], payload=payload)
        from_file = model.predict_trajectory(plan, payload=payload)
        for p in (from_arrays, from_file):
            assert p.energy_J == cli["energy_J"]
            assert p.interval_J == cli["interval_95_J"]
            assert p.duration_s == cli["duration_s"]
            assert p.mean_power_W == cli["mean_power_W"]
    assert from_file.power_W.shape == (table.shape[0],)


def test_sweep_without_twin_equals_cli(robot, work, tmp_path):
    d = work["dir"]
    model = pt.Model.load(d / "cli_model.json", robot)
    cli = run_cli("sweep", "--twin", "none", "--model", d / "cli_model.json", "--speeds", "0.3,0.6,1.0",
                  "--loads", "0,2", "--out", tmp_path / "cli", "--json")
    py = pt.sweep(robot, model, twin="none", speeds=[0.3, 0.6, 1.0], loads=[0, 2], out=tmp_path / "py")
    table = py.pop("table")
    assert py == json.loads(cli.stdout)
    assert (tmp_path / "py" / "sweep.json").read_bytes() == (tmp_path / "cli" / "sweep.json").read_bytes()
    assert np.array_equal(table["speed_m_s"], [0.3, 0.6, 1.0, 0.3, 0.6, 1.0])


def test_identified_model_pickles_to_the_same_predictions(robot, work):
    d = work["dir"]
    model = pt.Model.load(d / "cli_model.json", robot)
    again = pickle.loads(pickle.dumps(model))
    plan = work["plans"][0]
    assert again.predict_trajectory(plan).energy_J == model.predict_trajectory(plan).energy_J
    r = pickle.loads(pickle.dumps(robot))
    assert (r.name, r.dof, r.joint_names) == (robot.name, robot.dof, robot.joint_names)


def test_excite_set_writes_the_cli_set(robot, tmp_path):
    args = ["--set", 2, "--loads", "none,liu2018_load_2kg", "--duration", 10, "--rounds", 1, "--evals", 60]
    run_cli("excite", *args, "--out", tmp_path / "cli")
    design = pt.excite_set(robot, 2, loads=[None, "liu2018_load_2kg"], duration_s=10, rounds=1, evals=60,
                           out=tmp_path / "py")
    cli = {p.name: p.read_bytes() for p in sorted((tmp_path / "cli").iterdir())}
    assert {p.name: p.read_bytes() for p in sorted((tmp_path / "py").iterdir())} == cli
    first = np.loadtxt(tmp_path / "py" / sorted(n for n in cli if n.endswith(".csv"))[0], delimiter=",", skiprows=1)
    assert np.array_equal(design["trajectories"][0]["q_rad"], first[:, 1:1 + robot.dof])
    assert len(design["member_conds"]) == 2 and design["cond_final"] <= design["cond_initial"]


def test_dataset_items_of_a_family_equal_the_cli(robot, tmp_path):
    run_cli("dataset", "--count", 2, "--seed", 3, "--truth", "family:1", "--out", tmp_path / "cli")
    for j in range(2):
        pt.dataset_item(robot, j, tmp_path / "py", seed=3, truth="family:1")
        name = f"item_{j:06d}"
        assert files(tmp_path / "py" / name) == files(tmp_path / "cli" / name)
        meta = json.loads((tmp_path / "py" / name / "meta.json").read_text())
        # Item j runs robot j of family 1, the robot `validate --family N --seed 1` draws j-th.
        assert meta["family"]["seed"] == 1_000_000 + 10 * j
    with pytest.raises(ValueError, match="family seed"):
        pt.dataset_item(robot, 0, tmp_path / "bad", seed=3, truth="family:x")
