#!/usr/bin/env bash
# Prints the README's ray-count table: for every display in config/displays,
# POR at the centre and at the top-left corner, the Nyquist bound and the
# rays of the nyquist and seed layouts (gazecast mask --json).
#   scripts/mask-table.sh [path/to/gazecast]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-target/release/gazecast}
field() { grep -o "\"$1\":[^,}]*" | head -1 | cut -d: -f2 | tr -d '"'; }
echo "| display | gaze | Nyquist bound | nyquist rays (ratio) | seed rays (ratio) | fovea radius px (nyquist) | off-screen mesh vertices (nyquist) |"
echo "|---|---|---:|---:|---:|---:|---:|"
for f in config/displays/*.ron; do
  for gaze in centre corner; do
    args=(mask --json --display "$f")
    [ "$gaze" = corner ] && args+=(--gaze 0.5,0.5)
    n=$("$bin" "${args[@]}" --layout nyquist)
    s=$("$bin" "${args[@]}" --layout seed)
    printf '| %s | %s | %.0f | %s (%.3f) | %s (%.3f) | %.1f | %s |\n' \
      "$(basename "$f" .ron)" "$gaze" "$(echo "$n" | field nyquist_bound_rays)" \
      "$(echo "$n" | field rays)" "$(echo "$n" | field ratio_to_bound)" \
      "$(echo "$s" | field rays)" "$(echo "$s" | field ratio_to_bound)" \
      "$(echo "$n" | field fovea_radius_px)" "$(echo "$n" | field off_screen_vertices)"
  done
done
