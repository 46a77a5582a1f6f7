#!/usr/bin/env bash
# The BVH against the seed's uniform grid (Murphy 2007 §6.1.1): primary rays
# at 1920x1080, closest hit, one thread, median of 5, both in one run.
#   bench/bvh_vs_grid.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p raycast --example trace_rays
ex=target/release/examples/trace_rays
echo "| scene | triangles | BVH Mrays/s | grid Mrays/s | grid / BVH | hits (both) |"
echo "|---|---:|---:|---:|---:|---:|"
for s in search-task bunny stress; do
  b=$(RAYON_NUM_THREADS=1 $ex config/scenes/$s.ron config/displays/desktop-24in-1080p.ron)
  g=$(RAYON_NUM_THREADS=1 $ex config/scenes/$s.ron config/displays/desktop-24in-1080p.ron --grid)
  f() { echo "$1" | grep -o "\"$2\":[0-9.]*" | cut -d: -f2; }
  [ "$(f "$b" hits)" = "$(f "$g" hits)" ] || echo "WARNING: $s: hit counts differ"
  printf '| %s | %s | %.2f | %.2f | %.2f | %s |\n' "$s" "$(f "$b" triangles)" \
    "$(echo "$(f "$b" rays_per_s) / 1000000" | bc -l)" "$(echo "$(f "$g" rays_per_s) / 1000000" | bc -l)" \
    "$(echo "$(f "$g" rays_per_s) / $(f "$b" rays_per_s)" | bc -l)" "$(f "$b" hits)"
done
