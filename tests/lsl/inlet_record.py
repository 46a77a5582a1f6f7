#!/usr/bin/env python3
"""An independent LSL consumer for the tests (pylsl: the reference liblsl).

Resolves each stream given as NAME:TYPE (within --resolve-timeout s),
opens an inlet on each at once (so an outlet waiting for consumers sees
them), then pulls until every stream has been idle for --idle s after its
first sample, or --duration s have passed. Writes JSON to --out:

  {"streams": {NAME: {"info_xml": ..., "channel_format": ...,
                      "samples": [{"ts": float, "ts_hex": "...",
                                   "recv": pylsl.local_clock() when pulled,
                                   "values": [...], "bits": [...]}]}}}

Floats that are not finite are written as null; float32 samples also carry
their bit patterns ("bits", hex) so a test can compare bit for bit.
Run with LSLAPICFG pointing at tests/lsl/lsl_api.cfg (loopback only).
"""
import argparse
import json
import math
import struct
import sys
import time

import pylsl

try:  # pylsl 1.16+ keeps the error classes in pylsl.util
    from pylsl.util import LostError
except ImportError:  # pragma: no cover
    LostError = pylsl.LostError


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--stream", action="append", required=True, help="NAME:TYPE")
    ap.add_argument("--out", required=True)
    ap.add_argument("--resolve-timeout", type=float, default=30.0)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--idle", type=float, default=3.0)
    a = ap.parse_args()

    inlets = {}
    t0 = time.monotonic()
    for spec in a.stream:
        name, _, typ = spec.partition(":")
        pred = f"name='{name}'" + (f" and type='{typ}'" if typ else "")
        left = max(0.1, a.resolve_timeout - (time.monotonic() - t0))
        found = pylsl.resolve_bypred(pred, 1, left)
        if not found:
            print(f"inlet_record: no stream {spec} within {a.resolve_timeout} s", file=sys.stderr)
            return 2
        inlet = pylsl.StreamInlet(found[0], max_buflen=360, recover=False,
                                  processing_flags=0)
        inlet.open_stream(10.0)
        inlets[name] = inlet
    print("inlet_record: inlets open: " + ", ".join(inlets), file=sys.stderr, flush=True)

    out = {}
    for name, inlet in inlets.items():
        info = inlet.info(10.0)
        out[name] = {"info_xml": info.as_xml(),
                     "channel_format": info.channel_format(),
                     "samples": []}
    last = {name: None for name in inlets}
    lost = set()
    start = time.monotonic()
    while time.monotonic() - start < a.duration:
        got = False
        for name, inlet in inlets.items():
            while name not in lost:
                try:
                    sample, ts = inlet.pull_sample(timeout=0.0)
                except LostError:
                    # The outlet is gone (gazecast ended): nothing more comes.
                    lost.add(name)
                    last[name] = last[name] or time.monotonic() - a.idle
                    break
                if sample is None:
                    break
                got = True
                last[name] = time.monotonic()
                rec = {"ts": ts, "ts_hex": struct.pack(">d", ts).hex(),
                       "recv": pylsl.local_clock()}
                if isinstance(sample[0], str):
                    rec["values"] = sample
                else:
                    rec["values"] = [v if math.isfinite(v) else None for v in sample]
                    if out[name]["channel_format"] == pylsl.cf_float32:
                        rec["bits"] = [struct.pack(">f", v).hex() for v in sample]
                out[name]["samples"].append(rec)
        now = time.monotonic()
        if len(lost) == len(inlets) or all(
                t is not None and now - t > a.idle for t in last.values()):
            break
        if not got:
            time.sleep(0.01)
    with open(a.out, "w") as f:
        json.dump({"streams": out}, f)
    for name in lost:
        out[name]["lost"] = True
    counts = ", ".join(f"{n}: {len(s['samples'])}" for n, s in out.items())
    print(f"inlet_record: pulled {counts}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
