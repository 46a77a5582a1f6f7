#!/usr/bin/env bash
# Regenerates the synthesised device streams in tests/data with the device
# simulator (tracker_hal::sim). A test checks that this reproduces the
# committed files byte for byte, so the data and the simulator stay in step.
#   scripts/make-test-data.sh [path/to/gazecast]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-target/release/gazecast}
d=tests/data
"$bin" simulate --tracker config/trackers/iscan-binary.ron --out $d/iscan-binary-60hz.gzrec --csv $d/iscan-binary-60hz.csv --seconds 10 --rate 60 --seed 1
"$bin" simulate --tracker config/trackers/iscan-ascii.ron --out $d/iscan-ascii-60hz.gzrec --csv $d/iscan-ascii-60hz.csv --seconds 10 --rate 60 --seed 2
"$bin" simulate --tracker $d/iscan-binary-115200.ron --out $d/iscan-binary-240hz.gzrec --csv $d/iscan-binary-240hz.csv --seconds 10 --rate 240 --seed 3
"$bin" simulate --tracker $d/mouse-realistic.ron --out $d/mouse-120hz.gzrec --csv $d/mouse-120hz.csv --seconds 10 --seed 4
"$bin" simulate --tracker config/trackers/tobii-hid.ron --out $d/tobii-hid-50hz.gzrec --csv $d/tobii-hid-50hz.csv --seconds 10 --rate 50 --seed 7 --hid-log $d/tobii-hid-50hz.hidlog
"$bin" simulate --tracker config/trackers/tobii-hid.ron --out $d/tobii-hid-compact-120hz.gzrec --csv $d/tobii-hid-compact-120hz.csv --seconds 10 --rate 120 --seed 9 --hid-layout compact
