#!/usr/bin/env bash
# Makes the Python environment that holds the official BIDS validator
# (bids-validator-deno: the Deno build of the bids-standard validator,
# shipped as a wheel) in target/bids-venv, for the BIDS export's test.
# Safe to run repeatedly. Prints the validator's path.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/bids-venv
version=3.0.2
exe="$venv/bin/bids-validator-deno"
if ! "$venv/bin/pip" show bids-validator-deno 2>/dev/null | grep -qx "Version: $version"; then
  python3 -m venv "$venv" >&2
  "$venv/bin/pip" install --quiet --disable-pip-version-check "bids-validator-deno==$version" >&2
fi
echo "$PWD/$exe"
