#!/usr/bin/env bash
# Renders every method at three gazes on two scenes with two gazecast
# binaries, each reading its own checkout's config files, and compares the
# PNG bytes and the ray counts: a refactor must leave every frame the same.
#   bench/same_frames.sh OLD_BIN OLD_CHECKOUT NEW_BIN NEW_CHECKOUT [cpu|gpu]
# Prints a Markdown table; exits 1 if any frame or ray count differs.
set -euo pipefail
old=$1; oldroot=$2; new=$3; newroot=$4; backend=${5:-cpu}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
rays() { grep -o '"rays_total": [0-9]*' "$1" | awk '{print $2}'; }
status=0
echo "| scene | method | gaze | PNG | rays old | rays new |"
echo "|---|---|---|---|---:|---:|"
for scene in search-task bunny; do
  for m in full hybrid image simplify lod ulod layers; do
    for g in 640,512 200,150 1200,900; do
      for side in old new; do
        if [ "$side" = old ]; then bin=$old; root=$oldroot; else bin=$new; root=$newroot; fi
        (cd "$root" && "$bin" render --scene "config/scenes/$scene.ron" \
          --display config/displays/tobii-et1750-17in.ron --gaze "$g" --mode "$m" \
          --backend "$backend" --out "$out/$side.png" --stats "$out/$side.json" >/dev/null)
      done
      same=identical
      cmp -s "$out/old.png" "$out/new.png" || { same=DIFFERENT; status=1; }
      ro=$(rays "$out/old.json"); rn=$(rays "$out/new.json")
      [ "$ro" = "$rn" ] || status=1
      echo "| $scene | $m | $g | $same | $ro | $rn |"
    done
  done
done
exit $status
