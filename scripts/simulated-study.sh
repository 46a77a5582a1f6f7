#!/usr/bin/env bash
# A study of simulated participants, headless, analysed: N participants of
# DESIGN searched by the observer model of config/participants/ (a MODEL,
# not people: every file says synthetic), once with the rendering's effect
# on (rendering_matters: true) and once off (false), each analysed with
# `gazecast experiment analyze`.
#
#   scripts/simulated-study.sh OUT N [DESIGN] [DISPLAY] [MODEL]
#
# Writes OUT/on/ and OUT/off/ (session folders, analysis/ with report.md
# and stats.json) and prints one line per arm: the repeated-measures
# ANOVA's F, degrees of freedom, Greenhouse-Geisser p, and the mean search
# time of the control and of the other conditions. Participants run two at
# a time (GAZECAST_JOBS to change); the binary is target/release/gazecast
# (built if missing) or GAZECAST_BIN.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -lt 2 ]; then
  sed -n '2,16p' "$0" >&2
  exit 2
fi
out=$1
n=$2
design=${3:-config/experiments/inset-study.ron}
display=${4:-config/displays/tobii-et1750-17in.ron}
model=${5:-config/participants/search-observer.ron}
case $n in '' | *[!0-9]*) echo "N must be a whole number, not $n" >&2; exit 2 ;; esac
if [ "$n" -lt 2 ] || [ "$n" -gt 200 ]; then
  echo "N must be 2 to 200 (the repeated-measures ANOVA needs two participants)" >&2
  exit 2
fi
if [ -e "$out" ]; then
  echo "$out exists: give a new folder (nothing is overwritten)" >&2
  exit 2
fi
bin=${GAZECAST_BIN:-target/release/gazecast}
if [ -z "${GAZECAST_BIN:-}" ] && [ ! -x "$bin" ]; then
  cargo build --release --quiet -p gazecast-viewer --bin gazecast
fi
jobs=${GAZECAST_JOBS:-2}
mkdir -p "$out"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-${TMPDIR:-/tmp}}"
for arm in on off; do
  mkdir -p "$out/$arm"
  m="$out/$arm/observer.ron"
  if [ "$arm" = on ]; then
    sed 's/rendering_matters: *false/rendering_matters: true/' "$model" >"$m"
  else
    sed 's/rendering_matters: *true/rendering_matters: false/' "$model" >"$m"
  fi
  grep -q "rendering_matters: $([ "$arm" = on ] && echo true || echo false)" "$m" || {
    echo "$model: no rendering_matters field to switch" >&2
    exit 1
  }
  started=$(date +%s)
  seq 1 "$n" | xargs -P "$jobs" -I{} sh -c '
    id=$(printf "S%02d" "$1")
    "$2" experiment run "$3" --participant "$id" --participant-index $(( $1 - 1 )) \
      --tracker config/trackers/simulated-eye.ron --display "$4" --out "$5/data" \
      --simulate-participant $(( 1000 + $1 )) --participant-model "$6" \
      --headless --backend cpu --no-stimulus-pictures >"$5/$id.log" 2>&1 ||
      { echo "participant $id failed: see $5/$id.log" >&2; exit 255; }
  ' sh {} "$bin" "$design" "$display" "$out/$arm" "$m"
  took=$(( $(date +%s) - started ))
  "$bin" experiment analyze "$out/$arm"/data/*/sub-* --out "$out/$arm/analysis" >"$out/$arm/analyze.log"
  python3 - "$out/$arm/analysis/stats.json" "$arm" "$n" "$took" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
rm = s["rm_anova"].get("Done")
conds = [c for c in s["conditions"] if c["summary"]]
ctl = [c["summary"]["mean"] for c in conds if c["method"] == "full"]
rest = [c["summary"]["mean"] for c in conds if c["method"] != "full"]
line = f"effect {sys.argv[2]}: {sys.argv[3]} simulated participants in {sys.argv[4]} s; "
if rm:
    r = rm["rm"]
    line += f"RM-ANOVA F({r['df_conditions']:.0f},{r['df_error']:.0f}) = {r['f']:.3f}, GG p = {r['p_gg']:.3g}; "
else:
    line += f"RM-ANOVA skipped ({s['rm_anova']['Skipped']}); "
if ctl and rest:
    line += f"control {ctl[0]:.2f} s, other conditions {min(rest):.2f}-{max(rest):.2f} s (SYNTHETIC)"
print(line)
EOF
done
