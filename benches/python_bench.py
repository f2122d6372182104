"""Benchmarks of the Python package against the Rust library and the CLI (issue 32).

1. `Model.predict_trajectory` on a 10 s plan (100 Hz samples, arrays in) against the same
   work in Rust (`cargo bench --bench task -- predict_trajectory_plan_file`, criterion's
   median), target: within 10 %.
2. A 64-item dataset on a 2-worker Dask LocalCluster (one thread each) against
   `powertwin dataset --count 64` on 2 threads (RAYON_NUM_THREADS=2), target: within 15 %.

Run from the repository root with the package installed (python/ci.sh's venv) after
`cargo build --release`:

    target/py-venv/bin/python benches/python_bench.py [--skip-rust] [--count 64]
"""

import argparse
import json
import os
import pathlib
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import powertwin as pt

REPO = pathlib.Path(__file__).resolve().parents[1]
TARGET = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
CLI = TARGET / "release" / "powertwin"
sys.path.insert(0, str(REPO / "python" / "tests"))
from conftest import write_plan  # noqa: E402


def python_predict(model, t, q, repeats=30):
    model.predict_trajectory(t, q)  # warm up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        model.predict_trajectory(t, q)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def rust_predict(plan, model_path):
    env = dict(os.environ, POWERTWIN_BENCH_PLAN=str(plan), POWERTWIN_BENCH_MODEL=str(model_path))
    subprocess.run(["cargo", "bench", "--bench", "task", "--", "predict_trajectory_plan_file"],
                   cwd=REPO, env=env, check=True, stdout=subprocess.DEVNULL)
    est = TARGET / "criterion" / "predict_trajectory_plan_file" / "new" / "estimates.json"
    return json.loads(est.read_text())["median"]["point_estimate"] * 1e-9


def bench_predict(work, skip_rust):
    robot = pt.Robot.irb1200()
    plan = work / "plan10s.csv"
    t, q = write_plan(plan, robot.dof, 10.0, seed=7)
    subprocess.run([CLI, "simulate", "--trajectory", plan, "--out", work / "run"], check=True, capture_output=True)
    subprocess.run([CLI, "identify", "--data", work / "run", "--out", work / "model.json", "--holdout", "0"],
                   check=True, capture_output=True)
    model = pt.Model.load(work / "model.json", robot)
    py = python_predict(model, t, q)
    print(f"predict_trajectory, 10 s plan ({t.size} samples): Python {py * 1e3:.2f} ms (median)")
    if not skip_rust:
        rs = rust_predict(plan, work / "model.json")
        print(f"  Rust library {rs * 1e3:.2f} ms (criterion median): Python/Rust = {py / rs:.3f} "
              f"({'within' if py <= 1.10 * rs else 'NOT within'} 10 %)")


def bench_dataset(work, count):
    from distributed import Client, LocalCluster

    env = dict(os.environ, RAYON_NUM_THREADS="2")
    start = time.perf_counter()
    subprocess.run([CLI, "dataset", "--count", str(count), "--out", work / "cli"], env=env, check=True,
                   capture_output=True)
    cli = time.perf_counter() - start
    robot = pt.Robot.irb1200()
    with LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None, host="127.0.0.1") as cluster, \
            Client(cluster) as client:
        import powertwin.distributed as ptd

        ptd.dataset(client, robot, 1, work / "warm")  # workers import powertwin once
        start = time.perf_counter()
        table = ptd.dataset(client, robot, count, work / "dask", raise_on_failure=True)
        dask = time.perf_counter() - start
    assert table["status"] == ["ok"] * count
    print(f"dataset --count {count}: CLI on 2 threads {cli:.1f} s, Dask 2-worker LocalCluster {dask:.1f} s: "
          f"Dask/CLI = {dask / cli:.3f} ({'within' if dask <= 1.15 * cli else 'NOT within'} 15 %)")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--skip-rust", action="store_true", help="skip the criterion run (no cargo bench)")
    ap.add_argument("--count", type=int, default=64, help="dataset items (default 64)")
    args = ap.parse_args()
    work = pathlib.Path(tempfile.mkdtemp(prefix="powertwin-bench-"))
    try:
        bench_predict(work, args.skip_rust)
        bench_dataset(work, args.count)
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
