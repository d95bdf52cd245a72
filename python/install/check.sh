#!/usr/bin/env bash
# Checks that `pip install ./python` works as the README says: a fresh virtualenv, the
# package built by pip (maturin, through pyproject.toml) and installed as a wheel, then
# smoke.py run with the installed package: a board, and two nodes exchanging a packet over
# Zenoh on 127.0.0.1.
#
#   python/install/check.sh             the dev profile, in the workspace's target directory
#   python/install/check.sh --release   the release profile, as a user's `pip install` builds
#
# Needs Python >= 3.10 with venv, and PyPI (pip fetches maturin for the build). The build
# reuses the workspace's target directory (CARGO_TARGET_DIR if set, else target/), so the
# workspace crates compiled by `cargo test` are not compiled again. The wheel is abi3
# (one wheel for every CPython >= 3.10); the check says which tag it got.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
if [ -f scripts/lib.sh ]; then
  # shellcheck source=../../scripts/lib.sh
  source scripts/lib.sh
  need_cargo
fi

profile=dev
case "${1:-}" in
  "") ;;
  --release) profile=release ;;
  *) echo "python/install/check.sh: unknown option $1 (see the comment at the top)" >&2; exit 2 ;;
esac

python="${PYTHON:-python3}"
if ! "$python" -c 'import sys; sys.exit(sys.version_info < (3, 10))' 2>/dev/null; then
  echo "slate: Python >= 3.10 is required ($python)" >&2
  exit 1
fi
work="$(mktemp -d "${TMPDIR:-/tmp}/slate-install.XXXXXX")"
trap 'rm -rf "$work"' EXIT
echo "==> fresh virtualenv in $work/venv" >&2
if ! "$python" -m venv "$work/venv"; then
  echo "slate: could not create a virtualenv; on Debian/Ubuntu: apt-get install python3-venv" >&2
  exit 1
fi

echo "==> pip install ./python ($profile profile)" >&2
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}"
MATURIN_PEP517_ARGS="--profile $profile" "$work/venv/bin/python" -m pip install \
  --disable-pip-version-check --progress-bar off ./python

wheel_tag="$("$work/venv/bin/python" - <<'PY'
import importlib.metadata as m
wheel = m.distribution("slate").read_text("WHEEL") or ""
print(" ".join(l.split(": ", 1)[1] for l in wheel.splitlines() if l.startswith("Tag: ")))
PY
)"
echo "==> installed wheel: $wheel_tag" >&2
case "$wheel_tag" in
  *abi3*) ;;
  *) echo "slate: the wheel is not abi3 ($wheel_tag)" >&2; exit 1 ;;
esac

echo "==> python smoke.py (from outside the source tree)" >&2
cd "$work"
timeout 120 "$work/venv/bin/python" "$root/python/install/smoke.py"
