#!/usr/bin/env bash
# Makes the Python environment the LSL tests use as an independent peer:
# pylsl (whose wheel ships the reference C++ liblsl) in target/lsl-venv.
# Safe to run repeatedly. Prints the interpreter's path.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/lsl-venv
if ! "$venv/bin/python" -c 'import pylsl' >/dev/null 2>&1; then
  python3 -m venv "$venv" >&2
  "$venv/bin/pip" install --quiet --disable-pip-version-check 'pylsl==1.18.6' >&2
fi
echo "$PWD/$venv/bin/python"
