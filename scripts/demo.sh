#!/usr/bin/env bash
# Runs slate's demo. Until the multi-robot mission (`slate demo`) lands, this runs the
# Ground Surveillance Robot world on one board and prints what happened.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
need_cargo

step "building and running the GSR world example (release)"
cargo run --release -q -p slate-model --example gsr_world
