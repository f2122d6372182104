# powertwin in a container: the release binary on a slim base (target `cli`, the default),
# and a Dask worker image with the Python package (target `worker`).
#
#   docker build -t powertwin .                      # the CLI: docker run powertwin --help
#   docker build --target worker -t powertwin-worker .
#
# Used by docs/guide/scale-out.md (Kubernetes indexed Job, Dask workers). Without the Rerun
# viewer's SDK (`--no-default-features`) the build is about a third as long; add
# `--build-arg FEATURES=` (empty) to keep the default features.

# --- build: the binary and the wheel, in one target directory and profile -------------------
FROM rust:1.95-slim-trixie AS build
ARG FEATURES=--no-default-features
RUN apt-get update \
    && apt-get install -y --no-install-recommends python3 python3-venv \
    && rm -rf /var/lib/apt/lists/*
WORKDIR /src
COPY . .
RUN cargo build --release --locked ${FEATURES} \
    && python3 -m venv /opt/maturin \
    && /opt/maturin/bin/pip install --no-cache-dir "maturin>=1.9,<2" \
    && /opt/maturin/bin/maturin build --release --locked --manifest-path python/Cargo.toml \
        --out /wheels ${FEATURES}

# --- cli: the release binary on a slim base -------------------------------------------------
FROM debian:trixie-slim AS cli
COPY --from=build /src/target/release/powertwin /usr/local/bin/powertwin
COPY --from=build /src/scenarios /opt/powertwin/scenarios
WORKDIR /work
ENTRYPOINT ["powertwin"]

# --- worker: Python, the package and dask.distributed (a Dask worker or client) -------------
FROM python:3.11-slim-trixie AS worker
COPY --from=build /wheels /wheels
COPY --from=build /src/target/release/powertwin /usr/local/bin/powertwin
RUN pip install --no-cache-dir /wheels/powertwin-*.whl "distributed>=2024.1" \
    && rm -rf /wheels
WORKDIR /work

# The default target is the CLI.
FROM cli
