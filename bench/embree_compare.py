#!/usr/bin/env python3
"""Primary-ray throughput of gazecast's CPU caster against Embree, side by side.

Both trace exactly the same rays through exactly the same world triangles
(dumped by the raycast `trace_rays` example), closest hit only, one thread
each (embreex traces its rays on the calling thread; gazecast runs with
RAYON_NUM_THREADS=1). BVH builds are excluded on both sides. Median of 5.

Set up once:  python3 -m venv .venv && .venv/bin/pip install embreex numpy
Run:          .venv/bin/python bench/embree_compare.py [SCENE] [DISPLAY]
Defaults:     config/scenes/bunny.ron, config/displays/desktop-24in-1080p.ron
"""
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh

root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
scene = sys.argv[1] if len(sys.argv) > 1 else "config/scenes/bunny.ron"
display = sys.argv[2] if len(sys.argv) > 2 else "config/displays/desktop-24in-1080p.ron"

with tempfile.TemporaryDirectory() as tmp:
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    out = subprocess.run(
        ["cargo", "run", "--quiet", "--release", "-p", "raycast", "--example", "trace_rays", "--", scene, display, "--dump", tmp],
        cwd=root, env=env, check=True, capture_output=True, text=True)
    ours = json.loads(out.stdout.strip().splitlines()[-1])
    tris = np.fromfile(os.path.join(tmp, "triangles.f32"), dtype=np.float32).reshape(-1, 3, 3)
    rays = np.fromfile(os.path.join(tmp, "rays.f32"), dtype=np.float32).reshape(-1, 6)

origins = np.ascontiguousarray(rays[:, :3])
dirs = np.ascontiguousarray(rays[:, 3:])
es = rtcs.EmbreeScene()
TriangleMesh(es, tris)
es.run(origins[:16], dirs[:16])  # commit (builds Embree's BVH) outside the timing
times = []
for _ in range(5):
    t0 = time.perf_counter()
    prim = es.run(origins, dirs)
    times.append(time.perf_counter() - t0)
times.sort()
embree = {"seconds": times[2], "rays_per_s": len(rays) / times[2], "hits": int((prim >= 0).sum())}

print(f"scene {ours['scene']}: {ours['triangles']} triangles, {ours['rays']} primary rays, 1 thread each")
print(f"  gazecast: {ours['rays_per_s'] / 1e6:8.2f} Mrays/s  ({ours['seconds'] * 1e3:.1f} ms, {ours['hits']} hits; packets of 8)")
print(f"  single:   {ours['rays_per_s_single'] / 1e6:8.2f} Mrays/s  ({ours['seconds_single'] * 1e3:.1f} ms; one ray at a time)")
print(f"  Embree:   {embree['rays_per_s'] / 1e6:8.2f} Mrays/s  ({embree['seconds'] * 1e3:.1f} ms, {embree['hits']} hits)")
print(f"  ratio gazecast/Embree: {ours['rays_per_s'] / embree['rays_per_s']:.2f} (packets; goal >= 1.0), "
      f"{ours['rays_per_s_single'] / embree['rays_per_s']:.2f} (single rays)")
if abs(ours["hits"] - embree["hits"]) > 0.001 * len(rays):
    print("  WARNING: hit counts differ by more than 0.1 %: not the same work")
