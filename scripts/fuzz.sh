#!/usr/bin/env bash
# Builds slate's fuzz targets (fuzz/, docs/security.md "Fuzzing") with cargo-fuzz on the
# stable toolchain (libFuzzer, `--sanitizer none`: no nightly flag is needed) and runs each
# on a copy of its committed corpus (fuzz/corpus/TARGET), for a bounded time or count.
# A crash stops the script with the input saved under fuzz/artifacts/TARGET/.
#
#   bash scripts/fuzz.sh                      # every target, 20 s each
#   bash scripts/fuzz.sh 20 wire_decode       # the named targets only (CI names four)
#   bash scripts/fuzz.sh 600 ici_receive      # one target for 10 minutes
#   FUZZ_RUNS=10000000 bash scripts/fuzz.sh 0 wire_decode   # 10 M executions, no time limit
#
# Installs cargo-fuzz (pinned below) with `cargo install --locked` when missing. Builds in
# "${CARGO_TARGET_DIR:-target}/fuzz", so a later run reuses the build.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/lib.sh
need_cargo

CARGO_FUZZ_VERSION=0.13.2
SECONDS_EACH="${1:-20}"
shift || true

if ! cargo fuzz --version 2>/dev/null | grep -qF "$CARGO_FUZZ_VERSION"; then
  step "installing cargo-fuzz $CARGO_FUZZ_VERSION"
  cargo install --locked cargo-fuzz --version "$CARGO_FUZZ_VERSION"
fi

# node_config alone needs slate-node (and Zenoh): fuzz/Cargo.toml's `node` feature.
features() { if [ "$1" = node_config ]; then echo "--features node"; fi; }

CARGO_TARGET_DIR="$(realpath -m "${CARGO_TARGET_DIR:-target}")/fuzz"
export CARGO_TARGET_DIR
cd fuzz
targets=("$@")
if [ "${#targets[@]}" -eq 0 ]; then
  mapfile -t targets < <(cargo fuzz list)
fi
for target in "${targets[@]}"; do
  step "cargo fuzz build $target (stable, --sanitizer none, debug assertions on)"
  cargo fuzz build --sanitizer none $(features "$target") "$target"
done
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for target in "${targets[@]}"; do
  step "fuzz $target: ${SECONDS_EACH}s${FUZZ_RUNS:+, at most $FUZZ_RUNS runs} on its corpus"
  mkdir -p "$work/$target" "artifacts/$target" "corpus/$target"
  # New inputs go to the scratch directory first, so the committed corpus stays as it is.
  log="$work/$target.log"
  if ! cargo fuzz run --sanitizer none $(features "$target") "$target" "$work/$target" "corpus/$target" -- \
    -max_total_time="$SECONDS_EACH" -runs="${FUZZ_RUNS:--1}" -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 >"$log" 2>&1; then
    tail -n 40 "$log" >&2
    echo "slate: fuzz target $target failed (above); a crashing input is saved in fuzz/artifacts/$target/" >&2
    exit 1
  fi
  grep -E '^Done|stat::number_of_executed_units|stat::peak_rss_mb' "$log" >&2 || true
done
