"""Scale-out on Dask: the embarrassingly parallel work of powertwin mapped over a
`dask.distributed.Client`.

- `dataset(client, robot, count, out)`: the items of `powertwin dataset` (item j drawn from
  (seed, j) alone, written byte for byte as the CLI writes it); finished items are skipped,
  so an interrupted run resumes.
- `sweep(client, robot, ...)`: the cells of `powertwin sweep`, one task per cell, joined into
  the sweep.json `sweep --json` prints.
- `validate(client, robot, model)`: the held-out motions of `powertwin validate`, one task
  per motion, joined into what `validate --json` prints.
- `identify_fleet(client, fleet)`: one identification per robot of a fleet.

Every function returns a table (a dict of numpy arrays / lists, one row per item) with a
`status` column ("ok", "skipped" or "failed") and an `error` column: a task that raises is
reported on its row, never dropped; `raise_on_failure=True` raises after all tasks finished.
Workers need `powertwin` installed (the same version as the client); robots and models are
pickled to them. Each task runs one item on one thread: give the workers one thread each
(`LocalCluster(n_workers=N, threads_per_worker=1)`) and the item's own Rust code is
single-threaded. Units: s, kg, m/s, J.
"""

from __future__ import annotations

import os
import pathlib
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np

import powertwin as pt
from powertwin import _powertwin as _pt

__all__ = ["dataset", "sweep", "validate", "identify_fleet", "TaskFailures"]


class TaskFailures(RuntimeError):
    """Some tasks failed; `table` holds every row (`status`, `error`)."""

    def __init__(self, message: str, table: dict):
        super().__init__(message)
        self.table = table


def _gather(client, futures, keys):
    """(key, result or None, error text or None) of every future, in `keys` order."""
    from distributed import wait

    wait(futures)
    out = []
    for key, f in zip(keys, futures):
        if f.status == "finished":
            out.append((key, f.result(), None))
        else:
            exc = f.exception()
            out.append((key, None, f"{type(exc).__name__}: {exc}"))
    return out


def _finish(table: dict, what: str, raise_on_failure: bool) -> dict:
    failed = [f"{k}: {e}" for k, s, e in zip(table["item"], table["status"], table["error"]) if s == "failed"]
    if failed and raise_on_failure:
        raise TaskFailures(f"{len(failed)} of {len(table['item'])} {what} failed: " + "; ".join(failed), table)
    return table


def _dataset_task(robot, j, out, seed, payload, fmt, twin):
    return pt.dataset_item(robot, j, out, seed=seed, payload=payload, format=fmt, **twin)


def dataset(
    client,
    robot: pt.Robot,
    count: int,
    out: Union[str, os.PathLike],
    *,
    seed: int = 0,
    payload: Union[None, str, Sequence[str]] = None,
    format: str = "parquet",
    raise_on_failure: bool = False,
    **twin: Any,
) -> dict:
    """Items 0..count-1 of `powertwin dataset --count COUNT --seed SEED --out OUT` on the
    cluster, one task per item, written to OUT/item_NNNNNN as the CLI writes them (byte for
    byte, same twin options; `twin`: `powertwin.twin_options` without the seed). Items whose
    meta.json exists are skipped (resume). Returns the table: item, status, error, path,
    duration_s, energy_total_J, energy_grid_J (NaN where not run)."""
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if "seed" in twin:
        raise ValueError("dataset: the noise seed is drawn per item; pass the set's seed as seed=")
    pt.twin_options(**twin)  # bad options fail here, not on the workers
    items = list(range(int(count)))
    todo = [j for j in items if not (out / f"item_{j:06d}" / "meta.json").exists()]
    robot_f = client.scatter(robot, broadcast=True, hash=False)
    futures = [
        client.submit(_dataset_task, robot_f, j, str(out), int(seed), payload, format, twin, pure=False)
        for j in todo
    ]
    results = {j: (r, e) for j, r, e in _gather(client, futures, todo)}
    table = {k: [] for k in ("item", "status", "error", "path", "duration_s", "energy_total_J", "energy_grid_J")}
    for j in items:
        r, e = results.get(j, (None, None))
        status = "skipped" if j not in results else ("ok" if e is None else "failed")
        table["item"].append(j)
        table["status"].append(status)
        table["error"].append(e)
        table["path"].append(str(out / f"item_{j:06d}"))
        for key in ("duration_s", "energy_total_J", "energy_grid_J"):
            table[key].append(np.nan if r is None else r[key])
    table = {k: (np.asarray(v, dtype=np.float64) if k in ("duration_s", "energy_total_J", "energy_grid_J")
                 else (np.asarray(v) if k == "item" else v)) for k, v in table.items()}
    return _finish(table, "dataset items", raise_on_failure)


def _sweep_task(robot, model, scenario, speeds, loads, k, twin, opts, out, fmt):
    inner = None if model is None else model._m
    return _pt.sweep_cell(robot, inner, scenario, speeds, loads, k, twin, opts, out, fmt)


def sweep(
    client,
    robot: pt.Robot,
    model: Optional["pt.Model"] = None,
    *,
    scenario: Optional[Union[str, os.PathLike]] = None,
    speeds: Sequence[float],
    loads: Sequence[float],
    twin: str = "urdf",
    out: Optional[Union[str, os.PathLike]] = None,
    format: str = "parquet",
    allow_overload: bool = False,
    raise_on_failure: bool = False,
    **twin_settings: Any,
) -> dict:
    """The cells of `powertwin sweep` (TCP `speeds` in m/s x load levels `loads` in kg of the
    scenario, load-major) on the cluster, one task per cell (the same twin run and prediction
    as the CLI's), joined into sweep.json: when every cell ran, the returned dict is what
    `sweep --json` prints, with `table` (the cells as arrays, plus item, status, error).
    With failed cells, `cells`, `optima` and `pareto` are absent and the table reports them.
    With `out`, each cell's dataset is written there as the CLI names it."""
    speeds = [float(v) for v in pt._floats("speeds", speeds)]
    loads = [float(v) for v in pt._floats("loads", loads)]
    if not speeds or not loads:
        raise ValueError("speeds, loads: at least one of each (m/s, kg)")
    if twin == "none":
        raise ValueError("twin='none' runs no twin: call powertwin.sweep(..., twin='none') directly")
    opts = pt.twin_options(**twin_settings)
    scen = None if scenario is None else os.fspath(scenario)
    outs = None if out is None else os.fspath(out)
    n = len(speeds) * len(loads)
    robot_f = client.scatter(robot, broadcast=True, hash=False)
    model_f = None if model is None else client.scatter(model, broadcast=True, hash=False)
    futures = [
        client.submit(_sweep_task, robot_f, model_f, scen, speeds, loads, k, twin, opts, outs, format, pure=False)
        for k in range(n)
    ]
    rows = _gather(client, futures, list(range(n)))
    import json

    cells = [None if r is None else json.loads(r) for _, r, _ in rows]
    status = ["ok" if e is None else "failed" for _, _, e in rows]
    if all(s == "ok" for s in status):
        text, flagged = _pt.sweep_assemble(
            robot, None if model is None else model._m, scen, speeds, loads, twin,
            [r for _, r, _ in rows], bool(allow_overload),
        )
        doc = json.loads(text)
        if out is not None:
            pt._write_text_atomic(pathlib.Path(out) / "sweep.json", text)
        if flagged:
            import warnings

            warnings.warn(flagged, RuntimeWarning, stacklevel=2)
    else:
        doc = {}
    table = pt.cells_table([c if c is not None else {} for c in cells]) if all(cells) else {}
    table.update({"item": np.arange(n), "status": status, "error": [e for _, _, e in rows],
                  "speed_m_s": np.array([speeds[k % len(speeds)] for k in range(n)]),
                  "load_kg": np.array([loads[k // len(speeds)] for k in range(n)], dtype=np.float64)})
    doc["table"] = table
    _finish(table, "sweep cells", raise_on_failure)
    return doc


def _validate_task(robot, model, k, count, seed, max_payload, opts, out, fmt):
    return _pt.validate_motion(robot, model._m, k, count, seed, max_payload, opts, out, fmt)


def validate(
    client,
    robot: pt.Robot,
    model: "pt.Model",
    *,
    count: int = 30,
    seed: int = 90_210,
    max_payload: Optional[float] = None,
    out: Optional[Union[str, os.PathLike]] = None,
    format: str = "parquet",
    raise_on_failure: bool = False,
    **twin: Any,
) -> dict:
    """The held-out motions of `powertwin validate --count COUNT --seed SEED` (`max_payload`
    kg; default the drive's rated payload) on the cluster, one task per motion (its twin run
    and scores as the CLI's), joined into what `validate --json` prints when every motion
    ran; `table` lists each motion's status and error. With `out`, heldout.json and each
    motion's dataset (out/datasets/heldout_NN_KIND) are written as the CLI writes them."""
    import json

    opts = pt.twin_options(**twin)
    outs = None if out is None else os.fspath(out)
    robot_f = client.scatter(robot, broadcast=True, hash=False)
    model_f = client.scatter(model, broadcast=True, hash=False)
    futures = [
        client.submit(_validate_task, robot_f, model_f, k, int(count), int(seed), max_payload, opts, outs,
                      format, pure=False)
        for k in range(int(count))
    ]
    rows = _gather(client, futures, list(range(int(count))))
    status = ["ok" if e is None else "failed" for _, _, e in rows]
    doc = {}
    if all(s == "ok" for s in status):
        text = _pt.validate_assemble(int(seed), [r for _, r, _ in rows])
        doc = json.loads(text)
        if out is not None:
            pt._write_text_atomic(pathlib.Path(out) / "heldout.json", text)
    doc["table"] = {"item": np.arange(int(count)), "status": status, "error": [e for _, _, e in rows]}
    _finish(doc["table"], "held-out motions", raise_on_failure)
    return doc


def _read_on_worker(item):
    """A dataset directory or log file (str or path) read where the task runs; a Run with
    such a log keeps its payload."""
    if isinstance(item, pt.Run) and isinstance(item.log, (str, os.PathLike)):
        return pt.Run(_read_on_worker(item.log), item.payload)
    if isinstance(item, (str, os.PathLike)):
        path = pathlib.Path(item)
        return pt.read_dataset(path) if path.is_dir() else pt.read_log(path)
    return item


def _identify_task(robot, runs, kwargs):
    return pt.identify(robot, [_read_on_worker(r) for r in runs], **kwargs)


def identify_fleet(
    client,
    fleet: Mapping[str, tuple],
    *,
    raise_on_failure: bool = False,
    **identify_kwargs: Any,
) -> dict:
    """Identify every robot of a fleet on the cluster, one task per robot: `fleet` maps a
    name to `(robot, runs)`, runs being dataset directories or log files read on the worker
    (or `Run(path, payload)` for a known payload; the cluster must see the paths), and
    `identify_kwargs` are `powertwin.identify`'s options. Returns the table: item (name), status, error, model
    (a `powertwin.Model` or None)."""
    names = list(fleet)
    futures = [
        client.submit(_identify_task, fleet[name][0], list(fleet[name][1]), dict(identify_kwargs), pure=False)
        for name in names
    ]
    rows = _gather(client, futures, names)
    table = {
        "item": names,
        "status": ["ok" if e is None else "failed" for _, _, e in rows],
        "error": [e for _, _, e in rows],
        "model": [r for _, r, _ in rows],
    }
    return _finish(table, "identifications", raise_on_failure)
