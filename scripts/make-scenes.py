#!/usr/bin/env python3
"""Writes the generated scene files in config/scenes (search-task, stress).

The scenes are plain RON; this script only saves typing 25 or 300 objects.
Geometry (Murphy 2007 ch. 7): the 17" 1280x1024 display at 54 cm; objects
sit 20 mm behind the screen, so they are 560 mm from the eye.
"""
import math
import os
import random

here = os.path.join(os.path.dirname(__file__), "..", "config", "scenes")


def search_task():
    dist = 560.0
    size = 2 * dist * math.tan(math.radians(3.5 / 2))  # 3.5 deg per object
    whole = 2 * dist * math.tan(math.radians(20.0 / 2))  # 20 deg grid
    step = (whole - size) / 4
    lines = [
        "// The seed's search task (Murphy 2007 ch. 7): a 5x5 grid of similar",
        "// meshes, each about 3.5 deg of visual angle, the grid about 20 deg, for the",
        "// 17\" 1280x1024 display at 54 cm. Written by scripts/make-scenes.py.",
        "Scene(",
        '    name: "search-task",',
        "    background: (0.06, 0.06, 0.08),",
        "    meshes: {",
    ]
    for k in range(4):
        lines.append(f'        "bumpy{k}": Bumpy(triangles: 8000, amplitude: 0.12, seed: {k + 1}),')
    lines.append('        "target": Torus(major_radius: 0.72, minor_radius: 0.28, segments: 64, sides: 24),')
    lines += ["    },", "    materials: {",
              '        "clay": (diffuse: (0.75, 0.62, 0.5)),',
              '        "blue": (diffuse: (0.45, 0.55, 0.8)),',
              "    },", "    objects: ["]
    rng = random.Random(7)
    target = (3, 1)
    for r in range(5):
        for c in range(5):
            x = -whole / 2 + size / 2 + c * step
            y = whole / 2 - size / 2 - r * step
            mesh = "target" if (r, c) == target else f"bumpy{rng.randrange(4)}"
            mat = "blue" if (r + c) % 2 else "clay"
            rot = (rng.uniform(0, 360), rng.uniform(0, 360), 0.0)
            lines.append(
                f'        (mesh: "{mesh}", material: Some("{mat}"), translate_mm: ({x:.2f}, {y:.2f}, -20.0), '
                f"rotate_deg: ({rot[0]:.1f}, {rot[1]:.1f}, 0.0), scale_mm: {size / 2:.3f}),")
    lines += ["    ],",
              "    sampling: Foveated(refine: [Silhouette, Crease(angle_deg: 30.0), Depth(jump: 0.05)]),",
              "    passes: [],", ")", ""]
    return "\n".join(lines)


def stress():
    rng = random.Random(11)
    lines = [
        "// The seed's worst case (Murphy 2007 §8.2.3): many objects at many depths",
        "// (high depth complexity) and a few very large triangles close to the eye.",
        "// Written by scripts/make-scenes.py.",
        "Scene(",
        '    name: "stress",',
        "    meshes: {",
        '        "ball": Bumpy(triangles: 5000, amplitude: 0.2, seed: 9),',
        '        "ring": Torus(major_radius: 0.7, minor_radius: 0.3, segments: 48, sides: 16),',
        # Long thin triangles between the screen and the eye (z > 0), each
        # crossing the whole field of view at its depth.
        '        "sliver1": Triangle(a: (-60.0, -20.0, 380.0), b: (60.0, -14.0, 380.0), c: (-58.0, -12.0, 380.0)),',
        '        "sliver2": Triangle(a: (-20.0, 35.0, 420.0), b: (-12.0, -35.0, 420.0), c: (-16.0, 35.0, 420.0)),',
        '        "sliver3": Triangle(a: (60.0, 70.0, 300.0), b: (30.0, -70.0, 300.0), c: (66.0, 70.0, 300.0)),',
        "    },",
        "    materials: {",
        '        "a": (diffuse: (0.8, 0.35, 0.3)),',
        '        "b": (diffuse: (0.35, 0.7, 0.4)),',
        '        "c": (diffuse: (0.35, 0.45, 0.85)),',
        '        "glass": (diffuse: (0.9, 0.9, 0.6), specular: (0.8, 0.8, 0.8), shininess: 80.0),',
        "    },",
        "    objects: [",
    ]
    for k in range(300):
        z = -rng.uniform(0, 900)
        reach = 0.9 * (540 - z) / 540  # stay inside the view cone
        x = rng.uniform(-170, 170) * reach
        y = rng.uniform(-135, 135) * reach
        mesh = "ball" if k % 3 else "ring"
        mat = "abc"[k % 3]
        s = rng.uniform(8, 30)
        lines.append(
            f'        (mesh: "{mesh}", material: Some("{mat}"), translate_mm: ({x:.1f}, {y:.1f}, {z:.1f}), '
            f"rotate_deg: ({rng.uniform(0, 360):.0f}, {rng.uniform(0, 360):.0f}, 0.0), scale_mm: {s:.1f}),")
    for k in range(1, 4):
        lines.append(f'        (mesh: "sliver{k}", material: Some("glass"), translate_mm: (0.0, 0.0, 0.0), scale_mm: 1.0),')
    lines += ["    ],", ")", ""]
    return "\n".join(lines)


with open(os.path.join(here, "search-task.ron"), "w") as f:
    f.write(search_task())
with open(os.path.join(here, "stress.ron"), "w") as f:
    f.write(stress())
