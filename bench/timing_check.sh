#!/usr/bin/env bash
# Timing truth (issue 28): the same simulated participant, quiet and with
# two busy loops loading the machine, then pymovements' I-VT on each
# session's samples.
#
#   bench/timing_check.sh [TRIALS] [SEED]      (defaults: 8 trials, seed 1)
#
# Runs the seed design (config/experiments/murphy2007-search.ron) on the
# seed display with the realistic mouse emulator (tests/data/mouse-realistic.ron,
# 120 Hz), --backend cpu, in a window (Xvfb when there is no $DISPLAY).
# Prints each session's fixation count, the loaded/quiet ratio, each
# session's agreement with pymovements, and the clock model the session
# logged. The participant is simulated: every figure is synthetic.
# Makes its own Python environment (target/pm-venv: pymovements 0.28).
set -euo pipefail
cd "$(dirname "$0")/.."
TRIALS=${1:-8}
SEED=${2:-1}
OUT=target/timing-check
rm -rf "$OUT"
mkdir -p "$OUT"
scripts/system-deps.sh
cargo build --quiet --bin gazecast
BIN=target/debug/gazecast

if [ ! -x target/pm-venv/bin/python ]; then
  python3 -m venv target/pm-venv
  target/pm-venv/bin/pip install --quiet 'pymovements==0.28.0'
fi

XVFB_PID=
if [ -z "${DISPLAY:-}" ]; then
  export DISPLAY=:97
  Xvfb :97 -screen 0 1920x1080x24 -nolisten tcp >/dev/null 2>&1 &
  XVFB_PID=$!
  sleep 1
fi
LOAD_PIDS=()
cleanup() {
  for p in "${LOAD_PIDS[@]}"; do kill "$p" 2>/dev/null || true; done
  [ -n "$XVFB_PID" ] && kill "$XVFB_PID" 2>/dev/null || true
}
trap cleanup EXIT

session() { # name
  XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp} "$BIN" experiment run config/experiments/murphy2007-search.ron \
    --participant P01 --tracker tests/data/mouse-realistic.ron --backend cpu \
    --simulate-participant "$SEED" --max-trials "$TRIALS" --no-stimulus-pictures \
    --out "$OUT/$1" >"$OUT/$1.log" 2>&1
}

echo "quiet run ($TRIALS trials, seed $SEED)"
session quiet
echo "loaded run: two busy loops"
for _ in 1 2; do (while :; do :; done) & LOAD_PIDS+=($!); done
session loaded
for p in "${LOAD_PIDS[@]}"; do kill "$p" 2>/dev/null || true; done
LOAD_PIDS=()

fix() { awk -F'\t' 'NR > 1 && $3 == "fixation"' "$OUT/$1/murphy2007-search/sub-P01/events.tsv" | wc -l; }
q=$(fix quiet)
l=$(fix loaded)
echo "fixations: quiet $q, loaded $l (loaded/quiet $(python3 -c "print(f'{$l / $q:.4f}')"))"
# The clock model at the end of each session (clock.tsv's last row).
for s in quiet loaded; do
  awk -F'\t' -v s="$s" 'NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i } END {
      printf "%s: clock model after %s samples: drift %+.3f ppm, offset (mapped - device) %.1f us, delay %.1f us, %s causality corrections\n",
        s, $c["samples"], $c["drift_ppm"], $c["offset_us"], $c["delay_us"], $c["corrections"] }' \
    "$OUT/$s/murphy2007-search/sub-P01/clock.tsv"
done
# Over whole trials and over the searches alone (fixations ending after
# the search onset): the searches are on the participant's dated plan; the
# screens before them last as long as the machine takes to show them, so a
# loaded run looks at them for longer. First with the speed gazecast's
# I-VT uses (the angle between lines of sight), then with pymovements'
# per-axis degrees (pix2deg).
for v in angle pix2deg; do
  echo "pymovements I-VT, speed: $v"
  target/pm-venv/bin/python bench/ivt_compare.py --velocity "$v" \
    "$OUT/quiet/murphy2007-search/sub-P01" "$OUT/loaded/murphy2007-search/sub-P01" | grep -v '^\['
done
