#!/usr/bin/env bash
# Runs every test of slate: formatting, lints, the Rust test suites (unit, integration,
# property, doc, example, transport conformance over the simulator and over Zenoh on
# 127.0.0.1, the dashboard in headless Chromium), a short run of each fuzz target, then
# the Python package's tests, and
# `pip install ./python` in a fresh virtualenv.
# CI runs exactly this (.ci/run).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
need_cargo
need_chromium

step "cargo fmt --check"
cargo fmt --all -- --check

step "cargo clippy (warnings are errors)"
cargo clippy --workspace --all-targets -- -D warnings

step "cargo test"
cargo test --workspace

# node_config is left to on-demand runs: it builds slate-node, and with it all of Zenoh,
# with coverage instrumentation (tens of minutes cold on 2 cores).
step "fuzz targets: each for 20 s on its corpus (cargo-fuzz on stable, scripts/fuzz.sh)"
bash scripts/fuzz.sh 20 wire_decode ici_receive slate_parse slate_check

step "python package: build with maturin, then pytest"
bash python/build.sh

step "python package: pip install ./python in a fresh virtualenv, then a board and two nodes"
bash python/install/check.sh
