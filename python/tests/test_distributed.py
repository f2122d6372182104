"""powertwin.distributed on a 2-worker LocalCluster (localhost only): the CLI's outputs."""

import json
import shutil

import numpy as np
import pytest

import powertwin as pt
from conftest import run_cli

distributed = pytest.importorskip("distributed")
import powertwin.distributed as ptd  # noqa: E402


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, host="127.0.0.1")
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def tree(d):
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def test_dataset_of_16_items_equals_the_cli_byte_for_byte(client, robot, tmp_path):
    run_cli("dataset", "--count", 16, "--seed", 3, "--out", tmp_path / "cli")
    table = ptd.dataset(client, robot, 16, tmp_path / "dask", seed=3)
    assert table["status"] == ["ok"] * 16
    assert tree(tmp_path / "dask") == tree(tmp_path / "cli")
    assert len(tree(tmp_path / "cli")) == 16 * 3
    # Resume: a missing item is made again, the others are skipped.
    shutil.rmtree(tmp_path / "dask" / "item_000005")
    again = ptd.dataset(client, robot, 16, tmp_path / "dask", seed=3)
    assert again["status"] == ["skipped"] * 5 + ["ok"] + ["skipped"] * 10
    assert tree(tmp_path / "dask") == tree(tmp_path / "cli")
    assert np.isfinite(again["energy_total_J"][5]) and np.isnan(again["energy_total_J"][0])


def test_failed_items_are_reported_not_dropped(client, robot, tmp_path):
    table = ptd.dataset(client, robot, 3, tmp_path / "bad", payload="no_such_payload")
    assert table["status"] == ["failed"] * 3
    assert all("no_such_payload" in e for e in table["error"])
    assert not any(p.name.startswith("item_") for p in (tmp_path / "bad").iterdir())
    with pytest.raises(ptd.TaskFailures, match="3 of 3 dataset items failed"):
        ptd.dataset(client, robot, 3, tmp_path / "bad", payload="no_such_payload", raise_on_failure=True)


def test_sweep_of_12_cells_equals_sweep_json(client, robot, work, tmp_path):
    model_path = work["dir"] / "cli_model.json"
    cli = run_cli("sweep", "--model", model_path, "--speeds", "0.2,0.4,0.7,1.0", "--loads", "0,1,2",
                  "--out", tmp_path / "cli", "--json")
    model = pt.Model.load(model_path, robot)
    doc = ptd.sweep(client, robot, model, speeds=[0.2, 0.4, 0.7, 1.0], loads=[0, 1, 2], out=tmp_path / "dask")
    table = doc.pop("table")
    assert doc == json.loads(cli.stdout)
    assert table["status"] == ["ok"] * 12
    assert (tmp_path / "dask" / "sweep.json").read_bytes() == (tmp_path / "cli" / "sweep.json").read_bytes()
    for cell in (tmp_path / "cli").glob("sweep_*"):
        assert tree(tmp_path / "dask" / cell.name) == tree(cell)


def test_fleet_identification(client, robot, work):
    d = work["dir"]
    table = ptd.identify_fleet(client, {
        "cell-1": (robot, [str(d / "cli_run0")]),
        "cell-2": (robot, [str(d / "cli_run0"), str(d / "cli_run1")]),
        "broken": (robot, [str(d / "no_such_dataset")]),
    })
    assert table["status"] == ["ok", "ok", "failed"]
    assert "no_such_dataset" in table["error"][2]
    local = pt.identify(robot, [pt.read_dataset(d / "cli_run0")])
    assert table["model"][0].to_json() == local.to_json()


def test_validate_motions_equal_validate_json(client, robot, work, tmp_path):
    model_path = work["dir"] / "cli_model.json"
    cli = run_cli("validate", "--model", model_path, "--count", 4, "--out", tmp_path / "cli", "--json")
    model = pt.Model.load(model_path, robot)
    doc = ptd.validate(client, robot, model, count=4, out=tmp_path / "dask")
    table = doc.pop("table")
    assert table["status"] == ["ok"] * 4
    assert doc == json.loads(cli.stdout)
    assert tree(tmp_path / "dask") == tree(tmp_path / "cli")
