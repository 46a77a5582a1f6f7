#!/usr/bin/env python3
"""A pylsl gaze outlet for gazecast's LSL inlet tests.

usage: outlet_gaze.py NAME TYPE SOURCE_ID COUNT [FIRST] [--hold]

Opens a 120 Hz cf_float32 stream with channels ScreenX, ScreenY (0..1 of
the screen, XDF gaze metadata types ScreenX/ScreenY) and PupilDiameter,
waits up to 30 s for a consumer, then pushes samples FIRST..FIRST+COUNT-1
of a known trajectory at 120 Hz, each with an explicit timestamp
(t0 + k/120 on the LSL clock, t0 taken when pushing starts). Every 17th
sample has NaN gaze (a lost eye). Prints what it sent as CSV on stdout,
flushed line by line: `i,timestamp,x,y,pupil` with the timestamp and the
float32 values written so that Python's float() reads them back exactly
(x/y `nan` where NaN), then `done`. With --hold it then stays up until
killed; else it waits 2 s (so the last samples are delivered) and exits.
Run it with LSLAPICFG set to tests/lsl/lsl_api.cfg (loopback only).
"""
import math
import struct
import sys
import time

import pylsl


def f32(v):
    return struct.unpack("<f", struct.pack("<f", v))[0]


def sample(i):
    if i % 17 == 5:
        x = y = float("nan")
    else:
        x = f32(0.5 + 0.4 * math.sin(i * 0.05))
        y = f32(0.5 + 0.3 * math.cos(i * 0.07))
    return x, y, f32(3.0 + 0.001 * i)


def main():
    args = [a for a in sys.argv[1:] if a != "--hold"]
    hold = "--hold" in sys.argv[1:]
    name, stype, source_id, count = args[0], args[1], args[2], int(args[3])
    first = int(args[4]) if len(args) > 4 else 0
    info = pylsl.StreamInfo(name, stype, 3, 120.0, pylsl.cf_float32, source_id)
    chans = info.desc().append_child("channels")
    for label, kind, unit in [
        ("ScreenX", "ScreenX", "normalized"),
        ("ScreenY", "ScreenY", "normalized"),
        ("PupilDiameter", "Diameter", "mm"),
    ]:
        c = chans.append_child("channel")
        c.append_child_value("label", label)
        c.append_child_value("type", kind)
        c.append_child_value("unit", unit)
        c.append_child_value("eye", "both")
    outlet = pylsl.StreamOutlet(info)
    print("ready", flush=True)
    if not outlet.wait_for_consumers(30.0):
        print("no consumer", file=sys.stderr, flush=True)
        sys.exit(2)
    time.sleep(0.3)
    t0 = pylsl.local_clock()
    for k in range(count):
        i = first + k
        x, y, p = sample(i)
        ts = t0 + k / 120.0
        outlet.push_sample([x, y, p], ts)
        print(f"{i},{ts!r},{x!r},{y!r},{p!r}", flush=True)
        wake = t0 + (k + 1) / 120.0 - pylsl.local_clock()
        if wake > 0:
            time.sleep(wake)
    print("done", flush=True)
    if hold:
        while True:
            time.sleep(1)
    time.sleep(2.0)


if __name__ == "__main__":
    main()
