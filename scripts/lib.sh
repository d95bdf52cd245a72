# Shared by the scripts: find or explain the toolchain. Sourced, not run.

need_cargo() {
  if ! command -v cargo >/dev/null 2>&1 && [ -x "$HOME/.cargo/bin/cargo" ]; then
    export PATH="$HOME/.cargo/bin:$PATH"
  fi
  if ! command -v cargo >/dev/null 2>&1; then
    echo "slate: cargo (Rust >= 1.88) is required but not found." >&2
    echo "       Install it with rustup (https://rustup.rs), then run this again." >&2
    exit 1
  fi
  for component in rustfmt clippy; do
    if ! cargo "${component/rustfmt/fmt}" --version >/dev/null 2>&1; then
      echo "slate: installing the $component component" >&2
      rustup component add "$component" >&2 || { echo "slate: could not install $component" >&2; exit 1; }
    fi
  done
}

# In CI a step also says how much disk is left, so a full disk is plain in the log.
step() {
  printf '\n==> %s\n' "$*" >&2
  if [ -n "${CI:-}" ]; then df -h . 2>/dev/null | awk 'NR == 2 { print "    (disk: " $4 " free)" }' >&2 || true; fi
}

# The dashboard's browser test needs Debian's chromium; install it when we can (root),
# and make its absence a failure only when it is installed.
need_chromium() {
  if ! command -v chromium >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    step "installing chromium for the dashboard's browser test"
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
      || echo "slate: could not install chromium; the browser test will be skipped" >&2
  fi
  if command -v chromium >/dev/null 2>&1; then
    export SLATE_BROWSER_TESTS=1
  else
    export SLATE_BROWSER_TESTS=0
  fi
}
