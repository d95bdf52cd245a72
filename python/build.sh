#!/usr/bin/env bash
# Builds the slate Python package into the repository's virtualenv and runs its tests.
#
#   python/build.sh              build (dev profile) and run the pytest suite
#   python/build.sh --release    build with the release profile (for python/bench), and test
#   python/build.sh --no-test    build only
#   python/build.sh -- ARGS...   pass ARGS to pytest (e.g. -- -k watch -x)
#
# It creates .venv at the repository root if needed (python3 >= 3.10), installs the pinned
# tools of python/requirements-dev.txt, and runs `maturin develop`, which compiles
# crates/slate-python into the workspace's target/ directory (the same one cargo uses) and
# installs the package in editable mode: python/slate/ is imported directly, with the
# native module _slate*.so copied next to it.
#
# Profile: the dev profile by default, like `cargo build` and `cargo test`, so the
# workspace crates the extension depends on are compiled once for both. (maturin sets
# PYO3_PYTHON and PYO3_BUILD_EXTENSION_MODULE, so the small pyo3 crates and the extension
# itself are rebuilt after a plain `cargo` build; slate-model and slate-plans are not.)
# Benchmarks need --release: a debug build is several times slower.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
if [ -f scripts/lib.sh ]; then
  # shellcheck source=../scripts/lib.sh
  source scripts/lib.sh
  need_cargo
fi

profile=()
run_tests=1
pytest_args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --release) profile=(--release) ;;
    --no-test) run_tests=0 ;;
    --) shift; pytest_args=("$@"); break ;;
    *) echo "python/build.sh: unknown option $1 (see the comment at the top)" >&2; exit 2 ;;
  esac
  shift
done

venv="$root/.venv"
python="${PYTHON:-python3}"
if [ ! -x "$venv/bin/python" ]; then
  if ! "$python" -c 'import sys; sys.exit(sys.version_info < (3, 10))' 2>/dev/null; then
    echo "slate: Python >= 3.10 is required to build the Python package ($python)" >&2
    exit 1
  fi
  echo "==> creating $venv" >&2
  if ! "$python" -m venv "$venv"; then
    rm -rf "$venv"
    echo "slate: could not create $venv; on Debian/Ubuntu: apt-get install python3-venv" >&2
    exit 1
  fi
fi

# Install the tools once per version of the requirements file.
requirements="$root/python/requirements-dev.txt"
stamp="$venv/.slate-dev-$(cksum < "$requirements" | cut -d' ' -f1)"
if [ ! -f "$stamp" ]; then
  echo "==> installing $(grep -v '^#' "$requirements" | tr '\n' ' ')" >&2
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$requirements"
  touch "$stamp"
fi

echo "==> maturin develop ${profile[*]:-(dev profile)}" >&2
# A native module left by an earlier build under another name (the per-version
# `_slate.cpython-3XX-*.so` of builds before the abi3 wheel) would be imported before the
# `_slate.abi3.so` built now: remove every one first.
rm -f "$root"/python/slate/_slate.*.so
(
  cd "$root/python"
  VIRTUAL_ENV="$venv" PATH="$venv/bin:$PATH" "$venv/bin/maturin" develop --quiet ${profile[@]+"${profile[@]}"}
)

if [ "$run_tests" = 1 ]; then
  echo "==> pytest python/tests" >&2
  cd "$root/python"
  "$venv/bin/python" -m pytest ${pytest_args[@]+"${pytest_args[@]}"}
fi
