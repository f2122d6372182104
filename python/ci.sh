#!/usr/bin/env bash
# The Python half of CI (called by .ci/run after `cargo test --release`, which built
# target/release/powertwin): a virtual environment with the build and test tools from PyPI,
# the wheel built by maturin in the release profile and target directory, pytest over the
# package (parity with the CLI, a 2-worker Dask LocalCluster) and the quickstart example.
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-$PWD/target}"
venv="$target/py-venv"
start=$(date +%s)
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --disable-pip-version-check \
    "maturin>=1.9,<2" "numpy>=1.23" "pytest>=7" "distributed>=2024.1"
rm -rf "$target/wheels"
"$venv/bin/maturin" build --release --manifest-path python/Cargo.toml --out "$target/wheels" \
    --interpreter "$venv/bin/python"
"$venv/bin/pip" install --quiet --disable-pip-version-check --force-reinstall --no-deps \
    "$target"/wheels/powertwin-*.whl
"$venv/bin/python" -m pytest -q python/tests
"$venv/bin/python" python/examples/quickstart.py
echo "python: $(($(date +%s) - start)) s (venv, wheel, pytest, quickstart)"
