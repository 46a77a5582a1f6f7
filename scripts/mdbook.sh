#!/usr/bin/env bash
# Builds the user guide (docs/, an mdBook) into target/book and prints
# nothing else on success. Uses `mdbook` from PATH when it is the pinned
# version, else installs that version once with cargo into target/tools
# (about a minute and a half on 2 cores; only the HTML renderer, no server).
# The guide's links and commands are checked by crates/viewer/tests/guide.rs.
set -euo pipefail
cd "$(dirname "$0")/.."
version=0.5.4
mdbook=mdbook
if ! command -v mdbook >/dev/null 2>&1 || [ "$(mdbook --version)" != "mdbook v$version" ]; then
  mdbook=target/tools/bin/mdbook
  if [ ! -x "$mdbook" ] || [ "$("$mdbook" --version)" != "mdbook v$version" ]; then
    echo "installing mdbook $version into target/tools" >&2
    cargo install --quiet --locked --no-default-features --version "$version" --root target/tools mdbook
  fi
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
if ! "$mdbook" build --dest-dir target/book docs >"$log" 2>&1; then
  cat "$log" >&2
  exit 1
fi
# A warning (a missing page, a broken include, bad HTML) fails the build.
if grep -E 'WARN|ERROR' "$log" >&2; then
  exit 1
fi
