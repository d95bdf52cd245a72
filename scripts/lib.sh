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

step() { printf '\n==> %s\n' "$*" >&2; }
