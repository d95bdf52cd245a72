#!/usr/bin/env bash
# Runs every test of slate: formatting, lints, then the Rust test suites (unit,
# integration, property, doc and example tests). CI runs exactly this (.ci/run).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
need_cargo

step "cargo fmt --check"
cargo fmt --all -- --check

step "cargo clippy (warnings are errors)"
cargo clippy --workspace --all-targets -- -D warnings

step "cargo test"
cargo test --workspace
