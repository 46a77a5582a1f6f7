#!/usr/bin/env bash
# Runs gazecast from a checkout: installs missing system packages (or says
# which), builds the release binary, and runs it with your arguments.
#   ./gazecast.sh mask --png out/mask.png
set -euo pipefail
cd "$(dirname "$0")"
scripts/system-deps.sh
cargo build --release --quiet --bin gazecast
for arg in "$@"; do
  case "$arg" in */*) mkdir -p "$(dirname "$arg")" 2>/dev/null || true ;; esac
done
exec target/release/gazecast "$@"
