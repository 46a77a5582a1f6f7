#!/usr/bin/env bash
# Runs every check gazecast has: formatting, clippy and rustdoc (warnings are
# errors), the user guide's build, and every test of every crate, both tiers.
# Installs missing system packages first (or says which). CI runs this (.ci/run).
#   ./test.sh          fmt, clippy, doc, guide, the fast and the slow tier
#                      (everything; property tests at their full case count)
#   ./test.sh --fast   fmt, clippy, doc, guide, the fast tier
#                      (the tier `cargo test --workspace` runs)
#   ./test.sh --slow   the slow tier alone (the #[ignore]d tests)
# The tiers: docs/src/contributing/tests.md.
set -euo pipefail
cd "$(dirname "$0")"
tier=all
case "${1:-}" in
  "") ;;
  --fast) tier=fast ;;
  --slow) tier=slow ;;
  -h | --help)
    sed -n '2,11s/^# \{0,1\}//p' "$0"
    exit 0
    ;;
  *)
    echo "usage: ./test.sh [--fast | --slow]" >&2
    exit 2
    ;;
esac
[ $# -le 1 ] || { echo "usage: ./test.sh [--fast | --slow]" >&2; exit 2; }
scripts/system-deps.sh
if [ "$tier" != slow ]; then
  if ! cargo fmt --version >/dev/null 2>&1 || ! cargo clippy --version >/dev/null 2>&1; then
    rustup component add rustfmt clippy
  fi
  echo "== cargo fmt --check" >&2
  cargo fmt --all -- --check
  echo "== cargo clippy --all-targets -- -D warnings" >&2
  cargo clippy --workspace --all-targets --quiet -- -D warnings
fi
if [ "$tier" != slow ]; then
  echo "== cargo doc" >&2
  RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --quiet
  echo "== the user guide (mdbook build docs)" >&2
  scripts/mdbook.sh
fi
# The GPU tests run on Mesa's lavapipe where there is no GPU; its Wayland
# probe prints "XDG_RUNTIME_DIR is invalid" on headless machines unless the
# variable names some directory (the gazecast binary does the same).
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-${TMPDIR:-/tmp}}"
case "$tier" in
  fast)
    echo "== cargo test (the fast tier)" >&2
    args=()
    ;;
  slow)
    echo "== cargo test -- --ignored (the slow tier)" >&2
    args=(-- --ignored)
    ;;
  all)
    echo "== cargo test -- --include-ignored (both tiers)" >&2
    args=(-- --include-ignored)
    ;;
esac
if [ "$tier" != fast ]; then
  # Property tests at their full case count (fixtures::proptest_cases).
  export GAZECAST_SLOW_TIER=1
  # The Lab Streaming Layer tests talk to pylsl (the reference liblsl) as an
  # outside peer, in a virtual environment made here; LSL stays on 127.0.0.1.
  GAZECAST_PYLSL=$(scripts/lsl-venv.sh)
  export GAZECAST_PYLSL
  export LSLAPICFG="$PWD/tests/lsl/lsl_api.cfg"
  # The BIDS export's test runs the official validator (bids-validator-deno,
  # pinned, from PyPI) in a virtual environment made here.
  GAZECAST_BIDS_VALIDATOR=$(scripts/bids-venv.sh)
  export GAZECAST_BIDS_VALIDATOR
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
status=0
cargo test --workspace --quiet "${args[@]}" 2>&1 | tee "$log" || status=$?
# One closing line over every test binary (cargo prints one per binary, the
# last of which is often a doc-test run with nothing in it); the ignored
# count is the slow tier's tests that this run left out.
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i; if ($(i+1) ~ /^ignored/) g += $i } }
     END { printf "all tests: %d passed, %d failed", p, f; if (g) printf " (%d ignored: the slow tier, ./test.sh --slow)", g; printf "\n" }' "$log"
exit "$status"
