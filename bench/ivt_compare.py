#!/usr/bin/env python3
"""gazecast's fixations against pymovements' I-VT on the same samples.

For every completed trial of a session folder: the trial's samples up to
the response (timed rows only: `time_order` not repeated/backwards/ahead)
are converted to degrees by pymovements (`Gaze.pix2deg`, the session's
display), velocities are taken sample to preceding sample over the mapped
device-time interval, pymovements' `ivt` (15 deg/s, no minimum duration)
finds fixations, and the project's congruent-fixation merge (1 deg, 250 ms,
only saccades between; tracker-hal `merge_congruent_fixations`) joins them.
A gazecast fixation (events.tsv) agrees when a pymovements fixation has the
same first and last sample (the same mapped times). Counted over whole
trials and over the searches alone (fixations ending after the search
onset).

    bench/ivt_compare.py [--velocity angle|pix2deg] SESSION_DIR [SESSION_DIR ...]

Prints one line per session and a JSON summary line. Run by
bench/timing_check.sh, which makes the virtual environment.
"""
import csv
import json
import math
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pymovements as pm

CONGRUENT_DEG = 1.0
CONGRUENT_GAP_US = 250_000
THRESHOLD_DEG_S = 15.0
UNTIMED = {"repeated", "backwards", "ahead"}
# How a sample-to-sample speed is taken: "angle", the angle between the two
# lines of sight from the eye (what gazecast's I-VT uses), or "pix2deg",
# the step between pymovements' per-axis degrees of visual angle (a few
# per cent off the true angle away from the screen's centre, which moves
# samples near 15 deg/s across the threshold). --velocity pix2deg selects it.
VELOCITY = "angle"


def tsv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f, delimiter="\t"))


def num(v):
    return None if v in ("n/a", "") else float(v)


def display_of(session):
    """The session's display (session.json's `display`) in the names the
    rest of this script uses; the display's eye point is its centre (as
    for every shipped display)."""
    info = json.loads((session / "session.json").read_text())
    s = info["display"]
    d = {
        "resolution_px": (s["width_px"], s["height_px"]),
        "size_mm": (s["width_mm"], s["height_mm"]),
        "eye_distance_mm": s["distance_mm"],
    }
    return d, info


def degrees(rows, d):
    """pymovements' pix2deg of the rows' pixel positions (NaN for invalid)."""
    w, h = d["resolution_px"]
    sw, sh = d["size_mm"]
    exp = pm.Experiment(
        screen_width_px=int(w),
        screen_height_px=int(h),
        screen_width_cm=sw / 10.0,
        screen_height_cm=sh / 10.0,
        distance_cm=d["eye_distance_mm"] / 10.0,
        origin="upper left",
        sampling_rate=120.0,
    )
    xs = [r["x"] if r["x"] is not None else math.nan for r in rows]
    ys = [r["y"] if r["y"] is not None else math.nan for r in rows]
    df = pl.DataFrame({"time": [r["t"] / 1000.0 for r in rows], "x": xs, "y": ys})
    g = pm.Gaze(df, experiment=exp, time_column="time", time_unit="ms", pixel_columns=["x", "y"])
    g.pix2deg()
    pos = np.array(g.samples["position"].to_list(), dtype=float)
    return pos


MAX_SAMPLE_GAP_US = 50_000


def stretches(rows):
    """Runs of valid samples, split at invalid samples and at device-time
    steps over 50 ms (tracker-hal IvtConfig::max_sample_gap_us)."""
    out, cur = [], []
    for i, r in enumerate(rows):
        if r["x"] is None:
            if cur:
                out.append(cur)
            cur = []
            continue
        if cur and r["dev"] - rows[cur[-1]]["dev"] > MAX_SAMPLE_GAP_US:
            out.append(cur)
            cur = []
        cur.append(i)
    if cur:
        out.append(cur)
    return out


def fixations(rows, d):
    """pymovements I-VT fixations as (first, last) row indices, merged."""
    if not rows:
        return []
    pos = degrees(rows, d)
    t = np.array([r["t"] for r in rows], dtype=float)
    fx = []
    for run in stretches(rows):
        vel = np.zeros((len(run), 2))  # the first of a stretch: 0 (as gazecast)
        for j in range(1, len(run)):
            a, b = run[j - 1], run[j]
            dt = (t[b] - t[a]) * 1e-6
            step = pos[b] - pos[a]
            if VELOCITY == "angle":
                # The angle between the two lines of sight, in the
                # direction of pymovements' own step (its norm is what ivt
                # thresholds).
                norm = float(np.linalg.norm(step))
                speed = angle((rows[a]["x"], rows[a]["y"]), (rows[b]["x"], rows[b]["y"]), d) / dt
                vel[j] = step / norm * speed if norm > 0 else 0.0
            else:
                vel[j] = step / dt
        ev = pm.events.ivt(
            vel, timesteps=np.arange(len(run)), minimum_duration=0,
            velocity_threshold=THRESHOLD_DEG_S,
        )
        fx += [(run[int(a)], run[int(b)]) for a, b in zip(ev.frame["onset"], ev.frame["offset"])]
    return merge(sorted(fx), rows, d)


def angle(a, b, d):
    """The angle between the lines of sight to two screen points (degrees)."""
    w, h = d["resolution_px"]
    sw, sh = d["size_mm"]
    ex, ey = d.get("eye_point_px") or (w / 2.0, h / 2.0)
    px, py = sw / w, sh / h

    def ray(p):
        return np.array([(p[0] - ex) * px, (p[1] - ey) * py, d["eye_distance_mm"]])

    u, v = ray(a), ray(b)
    return math.degrees(math.atan2(np.linalg.norm(np.cross(u, v)), float(np.dot(u, v))))


def merge(fx, rows, d):
    """The project's congruent-fixation merge: consecutive fixations (only
    saccades between them: no blink or loss),
    centroids within 1 deg, gap at most 250 ms of device time; the joined
    centroid is duration-weighted (+1 ms)."""
    out = []
    for a, b in fx:
        c = centroid(rows, a, b)
        if out:
            a0, b0, c0 = out[-1]
            gap = rows[a]["dev"] - rows[b0]["dev"]
            if no_blink_between(rows, b0, a) and gap <= CONGRUENT_GAP_US and angle(c0, c, d) <= CONGRUENT_DEG:
                w0 = rows[b0]["dev"] - rows[a0]["dev"] + 1000
                w1 = rows[b]["dev"] - rows[a]["dev"] + 1000
                mix = [(c0[k] * w0 + c[k] * w1) / (w0 + w1) for k in range(2)]
                out[-1] = (a0, b, mix)
                continue
        out.append((a, b, c))
    return [(a, b) for a, b, _ in out]


def no_blink_between(rows, b0, a):
    """No blink or loss event between two fixations: every device-time step
    between consecutive valid samples is under 50 ms (tracker-hal's
    min_blink_us)."""
    valid = [k for k in range(b0, a + 1) if rows[k]["x"] is not None]
    return all(rows[q]["dev"] - rows[p]["dev"] < 50_000 for p, q in zip(valid, valid[1:]))


def centroid(rows, a, b):
    pts = [(r["x"], r["y"]) for r in rows[a : b + 1] if r["x"] is not None]
    return [sum(p[0] for p in pts) / len(pts), sum(p[1] for p in pts) / len(pts)]


def session_agreement(session):
    d, _ = display_of(session)
    samples = tsv(session / "samples.tsv")
    trials = tsv(session / "trials.tsv")
    events = [e for e in tsv(session / "events.tsv") if e["kind"] == "fixation"]
    # Counted over the whole trial (its screens up to the response) and
    # over the search alone (fixations that end after the search onset):
    # the search is on a dated plan, the screens before it last as long as
    # the machine takes to show them.
    totals = {"trial": [0, 0, 0], "search": [0, 0, 0]}
    for tr in trials:
        k, sitting, response = tr["trial"], tr["sitting"], int(tr["response_us"])
        onset = int(tr["search_onset_us"])
        rows = [
            {"t": int(s["mapped_us"]), "dev": int(s["device_us"]) if s["device_us"] != "n/a" else int(s["mapped_us"]),
             "x": num(s["x_px"]), "y": num(s["y_px"])}
            for s in samples
            if s["trial"] == k and s["sitting"] == sitting and s["time_order"] not in UNTIMED
            and int(s["mapped_us"]) <= response
        ]
        for r in rows:
            if r["x"] is None or r["y"] is None:
                r["x"] = r["y"] = None
        theirs = {(rows[a]["t"], rows[b]["t"]) for a, b in fixations(rows, d)}
        ours = {
            (int(e["onset_us"]), int(e["end_us"]))
            for e in events
            if e["trial"] == k and e["sitting"] == sitting
        }
        for key, keep in (("trial", lambda f: True), ("search", lambda f: f[1] >= onset)):
            o = {f for f in ours if keep(f)}
            t = {f for f in theirs if keep(f)}
            totals[key][0] += len(o)
            totals[key][1] += len(t)
            totals[key][2] += len(o & t)
    return totals


def main():
    global VELOCITY
    args = sys.argv[1:]
    if args[:1] == ["--velocity"]:
        VELOCITY, args = args[1], args[2:]
    summary = []
    for arg in args:
        totals = session_agreement(Path(arg))
        row = {"session": arg, "velocity": VELOCITY}
        for key, (ours, theirs, agree) in totals.items():
            share = agree / max(ours, theirs, 1)
            print(f"{arg} ({key}): gazecast {ours} fixations, pymovements {theirs}, "
                  f"the same first and last sample {agree} ({100 * share:.1f} %)")
            row[key] = {"gazecast": ours, "pymovements": theirs, "agree": agree, "share": share}
        summary.append(row)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
