#!/usr/bin/env bash
# Runs slate's demo: three robots and an operator console coordinated through slate, on
# the deterministic network simulator. Extra arguments go to `slate demo` (see
# `slate demo --help`: --seed, --robots, --network zenoh, --dashboard 127.0.0.1:8080, ...).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
need_cargo

# The build is visible (cargo prints each crate it compiles, and a progress bar on a
# terminal): on a fresh machine it takes minutes, which must not look like a hang.
step "building slate (release; the first build takes a few minutes)"
cargo build --release -p slate-cli

step "running the demo"
cargo run --release -q -p slate-cli -- demo "$@"
