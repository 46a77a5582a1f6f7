#!/usr/bin/env python3
"""Writes the generated scene files in config/scenes (search-task, stress, room).

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


def room():
    """A screen-filling room (issue 34): every primary ray of any display
    file hits something. The eye sits inside a closed box (floor, ceiling,
    two side walls, back wall; open only behind the eye, where no primary
    ray goes), and about 100 objects stand on the floor, float at many
    depths and crowd the view, some between the screen and the eye."""
    rng = random.Random(34)
    # The box: x in [-X, X], y in [-Y, Y], z from the back wall Z0 to Z1,
    # behind every display file's eye (at most 800 mm).
    X, Y, Z0, Z1 = 450.0, 330.0, -1800.0, 900.0
    lines = [
        "// A screen-filling room (issue 34): the eye inside a closed box (floor,",
        "// ceiling, side and back walls, two triangles each), about 100 objects at",
        "// every depth from the back wall to between the screen and the eye; every",
        "// primary ray hits. About 306 k triangles. Written by scripts/make-scenes.py.",
        "Scene(",
        '    name: "room",',
        "    background: (0.0, 0.0, 0.0),",
        "    meshes: {",
        '        "ball": Bumpy(triangles: 5000, amplitude: 0.15, seed: 21),',
        '        "rock": Bumpy(triangles: 3000, amplitude: 0.3, seed: 22),',
        '        "ring": Torus(major_radius: 0.7, minor_radius: 0.3, segments: 48, sides: 16),',
        '        "orb": Icosphere(subdivisions: 3),',
    ]
    # Each wall a quad (a, b, c, d) in order round it, as two triangles.
    walls = {
        "floor": [(-X, -Y, Z1), (X, -Y, Z1), (X, -Y, Z0), (-X, -Y, Z0)],
        "ceiling": [(-X, Y, Z0), (X, Y, Z0), (X, Y, Z1), (-X, Y, Z1)],
        "left": [(-X, -Y, Z0), (-X, Y, Z0), (-X, Y, Z1), (-X, -Y, Z1)],
        "right": [(X, -Y, Z1), (X, Y, Z1), (X, Y, Z0), (X, -Y, Z0)],
        "back": [(-X, -Y, Z0), (X, -Y, Z0), (X, Y, Z0), (-X, Y, Z0)],
    }
    v = lambda p: f"({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f})"
    for name, (a, b, c, d) in walls.items():
        lines.append(f'        "{name}0": Triangle(a: {v(a)}, b: {v(b)}, c: {v(c)}),')
        lines.append(f'        "{name}1": Triangle(a: {v(a)}, b: {v(c)}, c: {v(d)}),')
    lines += [
        "    },",
        "    materials: {",
        '        "wall": (diffuse: (0.7, 0.68, 0.62), specular: (0.05, 0.05, 0.05), shininess: 8.0),',
        '        "floor": (diffuse: (0.45, 0.33, 0.22), specular: (0.1, 0.1, 0.1), shininess: 16.0),',
        '        "a": (diffuse: (0.8, 0.35, 0.3)),',
        '        "b": (diffuse: (0.35, 0.7, 0.4)),',
        '        "c": (diffuse: (0.35, 0.45, 0.85)),',
        "    },",
        "    objects: [",
    ]
    for name in walls:
        mat = "floor" if name == "floor" else "wall"
        for k in range(2):
            lines.append(
                f'        (mesh: "{name}{k}", material: Some("{mat}"), translate_mm: (0.0, 0.0, 0.0), '
                f"scale_mm: 1.0, importance: 0.0),")
    # 25 balls, 20 rocks, 20 rings, 35 orbs: 128 k + 102 k + 30.7 k + 44.8 k.
    kinds = ["ball"] * 25 + ["rock"] * 20 + ["ring"] * 20 + ["orb"] * 35
    rng.shuffle(kinds)
    for k, mesh in enumerate(kinds):
        z = rng.uniform(Z0 + 150, 350)
        s = rng.uniform(25, 110) if z < 0 else rng.uniform(12, 30)
        # Within the box; near the eye, within the view but off its centre.
        reach = min(1.0, (540 - z) / 540 * 0.9)
        x = rng.uniform(-(X - s), X - s) * (reach if z > -300 else 1.0)
        on_floor = rng.random() < 0.4 and z < 0
        y = -Y + s if on_floor else rng.uniform(-(Y - s), Y - s) * (reach if z > -300 else 1.0)
        mat = "abc"[k % 3]
        lines.append(
            f'        (mesh: "{mesh}", material: Some("{mat}"), translate_mm: ({x:.1f}, {y:.1f}, {z:.1f}), '
            f"rotate_deg: ({rng.uniform(0, 360):.0f}, {rng.uniform(0, 360):.0f}, 0.0), scale_mm: {s:.1f}),")
    lines += ["    ],",
              "    lights: [Headlight(intensity: 0.6), Point(position_mm: (0.0, 300.0, -600.0), intensity: 0.6)],",
              "    sampling: Foveated(refine: [Silhouette, Crease(angle_deg: 30.0), Depth(jump: 0.05)]),",
              "    passes: [],", ")", ""]
    return "\n".join(lines)


with open(os.path.join(here, "search-task.ron"), "w") as f:
    f.write(search_task())
with open(os.path.join(here, "stress.ron"), "w") as f:
    f.write(stress())
with open(os.path.join(here, "room.ron"), "w") as f:
    f.write(room())
