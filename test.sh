#!/usr/bin/env bash
# Runs every check gazecast has: formatting, clippy (warnings are errors) and
# every test of every crate. Installs missing system packages first (or says
# which). CI runs exactly this (.ci/run).
set -euo pipefail
cd "$(dirname "$0")"
scripts/system-deps.sh
if ! cargo fmt --version >/dev/null 2>&1 || ! cargo clippy --version >/dev/null 2>&1; then
  rustup component add rustfmt clippy
fi
echo "== cargo fmt --check" >&2
cargo fmt --all -- --check
echo "== cargo clippy --all-targets -- -D warnings" >&2
cargo clippy --workspace --all-targets --quiet -- -D warnings
echo "== cargo test" >&2
cargo test --workspace --quiet
