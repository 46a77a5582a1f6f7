#!/usr/bin/env bash
# Foveated versus full-resolution frame time on the CPU, side by side in one
# run: median of 5 frames each, gaze at the screen centre.
#   bench/foveated_vs_full.sh [path/to/gazecast]
# SCENES and DISPLAYS (names in config/scenes and config/displays, space
# separated) choose others, e.g. the screen-filling room at the seed's
# 1280x1024:  SCENES="room search-task bunny" DISPLAYS=tobii-et1750-17in bench/foveated_vs_full.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-target/release/gazecast}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
field() { grep -o "\"$1\": [0-9.]*" "$2" | head -1 | awk '{print $2}'; }
echo "| scene | display | full ms | foveated ms | full / foveated | rays full | rays foveated | cells refined |"
echo "|---|---|---:|---:|---:|---:|---:|---:|"
for scene in ${SCENES:-search-task bunny stress room}; do
  for display in ${DISPLAYS:-desktop-24in-1080p desktop-27in-4k}; do
    for mode in full foveated; do
      "$bin" render --scene "config/scenes/$scene.ron" --display "config/displays/$display.ron" \
        --mode "$mode" --repeat 5 --out "$tmp/$mode.png" --stats "$tmp/$mode.json" >/dev/null
    done
    f=$(field time_ms "$tmp/full.json"); v=$(field time_ms "$tmp/foveated.json")
    printf '| %s | %s | %.0f | %.0f | %.2f | %s | %s | %s of %s |\n' "$scene" "$display" "$f" "$v" \
      "$(echo "$f / $v" | bc -l)" "$(field rays_total "$tmp/full.json")" "$(field rays_total "$tmp/foveated.json")" \
      "$(field cells_refined "$tmp/foveated.json")" "$(field cells_total "$tmp/foveated.json")"
  done
done
echo
echo "threads: $(grep -o '"threads": [0-9]*' "$tmp/full.json" | awk '{print $2}'), machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
