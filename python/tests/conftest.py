"""Shared fixtures: the CLI binary the bindings are compared with, plans written as CSV."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

import powertwin as pt

REPO = pathlib.Path(__file__).resolve().parents[2]


def cli_path() -> pathlib.Path:
    """The release `powertwin` binary: $POWERTWIN_BIN, else $CARGO_TARGET_DIR/release/powertwin,
    else target/release/powertwin of the repository."""
    if os.environ.get("POWERTWIN_BIN"):
        return pathlib.Path(os.environ["POWERTWIN_BIN"])
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    return target / "release" / "powertwin"


def run_cli(*args, check=True) -> subprocess.CompletedProcess:
    """Run the CLI with `args` (str or paths); stdout and stderr captured as text."""
    exe = cli_path()
    if not exe.exists():
        pytest.fail(f"{exe} not found: build it with `cargo build --release` first")
    p = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True)
    if check and p.returncode != 0:
        raise AssertionError(f"powertwin {' '.join(map(str, args))} failed ({p.returncode}):\n{p.stderr}")
    return p


def write_plan(path: pathlib.Path, dof: int, duration_s: float, seed: int, rate_hz: float = 100.0):
    """A rest-to-rest multi-sine plan (t_s, q1_rad..qn_rad) within the IRB 1200's limits,
    written with exact float text (repr), so the CLI and numpy read the same bits."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s + 1e-9, 1.0 / rate_hz)
    env = np.sin(np.pi * t / duration_s) ** 2
    q = np.empty((t.size, dof))
    for j in range(dof):
        amp, f, phi = rng.uniform(0.2, 0.45), rng.uniform(0.15, 0.5), rng.uniform(0, 2 * np.pi)
        q[:, j] = amp * env * np.sin(2 * np.pi * f * t + phi)
    lines = ["t_s," + ",".join(f"q{j + 1}_rad" for j in range(dof))]
    for k in range(t.size):
        lines.append(",".join(repr(float(v)) for v in [t[k], *q[k]]))
    path.write_text("\n".join(lines) + "\n")
    return t, q


@pytest.fixture(scope="session")
def robot():
    return pt.Robot.irb1200()


@pytest.fixture(scope="session")
def work(tmp_path_factory, robot):
    """Two plans, their twin runs by the CLI (seeds 1 and 2) and a model identified by the
    CLI from the first run; shared by the parity tests."""
    d = tmp_path_factory.mktemp("parity")
    plans = []
    for k in range(2):
        plan = d / f"plan{k}.csv"
        write_plan(plan, robot.dof, 8.0, seed=10 + k)
        run_cli("simulate", "--trajectory", plan, "--out", d / f"cli_run{k}", "--noise-seed", k + 1)
        plans.append(plan)
    run_cli("identify", "--data", d / "cli_run0", "--out", d / "cli_model.json", "--holdout", "0",
            "--export-urdf", d / "cli_identified.urdf")
    return {"dir": d, "plans": plans}
