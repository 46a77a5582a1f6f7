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
echo "== cargo doc" >&2
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --quiet
echo "== the user guide (mdbook build docs)" >&2
scripts/mdbook.sh
echo "== cargo test" >&2
# The GPU tests run on Mesa's lavapipe where there is no GPU; its Wayland
# probe prints "XDG_RUNTIME_DIR is invalid" on headless machines unless the
# variable names some directory (the gazecast binary does the same).
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-${TMPDIR:-/tmp}}"
# The Lab Streaming Layer tests talk to pylsl (the reference liblsl) as an
# outside peer, in a virtual environment made here; LSL stays on 127.0.0.1.
GAZECAST_PYLSL=$(scripts/lsl-venv.sh)
export GAZECAST_PYLSL
export LSLAPICFG="$PWD/tests/lsl/lsl_api.cfg"
# The BIDS export's test runs the official validator (bids-validator-deno,
# pinned, from PyPI) in a virtual environment made here.
GAZECAST_BIDS_VALIDATOR=$(scripts/bids-venv.sh)
export GAZECAST_BIDS_VALIDATOR
log=$(mktemp)
trap 'rm -f "$log"' EXIT
cargo test --workspace --quiet 2>&1 | tee "$log"
# One closing line over every test binary (cargo prints one per binary, the
# last of which is often a doc-test run with nothing in it).
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i } }
     END { printf "all tests: %d passed, %d failed\n", p, f }' "$log"
