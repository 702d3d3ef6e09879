"""``bench general``'s scenes: drawn from a seed and rendered photoreal with Blender's Cycles, with truth.

:func:`describe_scene` draws a scene from a seed: a support with a procedural texture (wood, cloth, paper, a
printed board, tiles), sometimes a wall behind with a shelf on it; a few groups of objects of many kinds
(boxes, books, cups, bowls, bottles, fruit-like blobs, coins and cards, toys, a plant in its pot), alone,
stacked, piled, in a bowl, on the shelf or hung on the wall, hiding one another; a camera at a pitch of 0–90°
and a vertical field of view of 25–80°, framing them; a sun and an area light of varied colour, direction and
softness. :func:`render_scene` hands it to ``blender_scene.py`` in the Python that has ``bpy``
(``PHYSOMNI_BLENDER_PYTHON``) and writes the scene's folder: ``photo.png``, per object ``modal_K.png``
(visible, from Blender's object-id render) and ``amodal_K.png`` (its whole outline, ray cast alone), and
``truth.json`` (camera intrinsics and pose, each object's label, pose, size and what holds it: ``on``, the
support, the shelf, the wall, another object's name, or the names of the several it rests on); :func:`load_rendered` reads
such a folder back instead of rendering it again.
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import subprocess
import sys
import time

import cv2
import numpy as np
import trimesh

from ..errors import InputError
from ..geometry.camera import PinholeCamera


#: Image size, path-tracing samples and CPU threads of a scene: a few seconds to ~20 s of Cycles on 2 cores.
SIZE = (320, 240)
SAMPLES = 24
THREADS = 2
#: Smallest visible area of an object given to the build, in pixels: a sliver nobody would select is left
#: out of the scene altogether (and the scene drawn on without it).
MIN_VISIBLE_PX = 80
#: The id image stores object k as red k * ID_STEP (blender_scene.ID_STEP).
ID_STEP = 4


class NoBlender(InputError):
    """No Python with Blender's ``bpy`` to render the scenes with: a missing prerequisite, refused as bad
    input is (exit 2)."""


def blender_python() -> str:
    """The Python with ``bpy``: ``PHYSOMNI_BLENDER_PYTHON``, else this one if it has it; NoBlender if none."""
    exe = os.environ.get("PHYSOMNI_BLENDER_PYTHON")
    if exe:
        return exe
    probe = subprocess.run([sys.executable, "-c", "import bpy"], capture_output=True)
    if probe.returncode == 0:
        return sys.executable
    raise NoBlender("bench general renders with Blender's Python module: install bpy==5.0.1 in an environment of "
                    "its own (it pins numpy<2) and set PHYSOMNI_BLENDER_PYTHON to that environment's python")


# --- the objects: canonical meshes, base on z = 0, centred on the z axis -------------------------------------

def _colour(rng, lo=0.05, hi=0.85):
    return [float(x) for x in rng.uniform(lo, hi, 3)]


def _revolve(profile, sections=48) -> trimesh.Trimesh:
    return trimesh.creation.revolve(np.asarray(profile, float), sections=sections)


def _blob(rng, radius: float, squash: float = 0.92, bumps: float = 0.04) -> trimesh.Trimesh:
    """A fruit-like body: a sphere with a few low-frequency bumps, a little squashed, base at z = 0."""
    m = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    v = m.vertices
    k = rng.normal(size=(3, 3))
    ph = rng.uniform(0, 2 * np.pi, 3)
    r = 1.0 + bumps * sum(np.sin(v @ k[i] * 2.0 + ph[i]) for i in range(3)) / 3.0
    m.vertices = v * r[:, None] * radius * np.array([1.0, 1.0, squash])
    m.apply_translation([0, 0, -m.bounds[0][2]])
    return m


def make_object(kind: str, rng) -> dict:
    """One object of ``kind``: its label, canonical mesh, Blender material and whether it is shaded smooth."""
    u = rng.uniform
    if kind == "box":
        m = trimesh.creation.box((u(0.08, 0.3), u(0.06, 0.22), u(0.05, 0.2)))
        mat = ({"kind": "mottled", "colours": [[0.45, 0.3, 0.17], [0.38, 0.25, 0.13]], "scale": 30.0,
                "roughness": 0.8, "bump": 0.1} if u() < 0.4 else
               {"kind": "print", "colours": [_colour(rng), _colour(rng)], "scale": u(3, 12), "roughness": 0.4})
        label, smooth = "box", False
    elif kind == "book":
        m = trimesh.creation.box((u(0.14, 0.25), u(0.1, 0.17), u(0.015, 0.05)))
        mat = {"kind": "print", "colours": [_colour(rng), _colour(rng)], "scale": u(2, 8), "roughness": 0.5}
        label, smooth = "book", False
    elif kind == "cup":
        r, h, w = u(0.033, 0.045), u(0.075, 0.1), 0.004
        body = _revolve([[0, 0], [r * 0.85, 0], [r, h], [r - w, h], [r * 0.85 - w, 0.006], [0, 0.006]])
        handle = trimesh.creation.torus(major_radius=0.022, minor_radius=0.005, major_sections=24,
                                        minor_sections=8)
        handle.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
        handle.apply_translation([r + 0.01, 0, 0.55 * h])
        m = trimesh.util.concatenate([body, handle])
        mat = {"kind": "plain", "colours": [_colour(rng, 0.3, 0.95)], "roughness": 0.15, "scale": 20.0}
        label, smooth = "cup", True
    elif kind == "bowl":
        r, h, w = u(0.07, 0.1), u(0.045, 0.065), 0.005
        m = _revolve([[0, 0], [0.55 * r, 0], [r, h], [r - w, h], [0.55 * r - w, 0.007], [0, 0.007]], 64)
        mat = {"kind": "plain", "colours": [_colour(rng, 0.3, 0.95)], "roughness": 0.2, "scale": 15.0}
        label, smooth = "bowl", True
    elif kind == "bottle":
        r, h = u(0.03, 0.045), u(0.18, 0.3)
        neck = u(0.011, 0.016)
        m = _revolve([[0, 0], [r, 0], [r, 0.62 * h], [neck * 1.1, 0.82 * h], [neck, 0.84 * h], [neck, h],
                      [0, h]])
        mat = {"kind": "plain", "colours": [_colour(rng, 0.02, 0.5)], "roughness": 0.1, "scale": 10.0}
        label, smooth = "bottle", True
    elif kind == "fruit":
        label, colours = [("apple", [[0.6, 0.05, 0.04], [0.75, 0.55, 0.1]]),
                          ("orange", [[0.85, 0.35, 0.02], [0.9, 0.45, 0.05]]),
                          ("lemon", [[0.85, 0.7, 0.05], [0.7, 0.65, 0.1]])][int(rng.integers(3))]
        m = _blob(rng, u(0.032, 0.045), squash=0.9 if label == "apple" else 1.0)
        mat = {"kind": "mottled", "colours": colours, "scale": 25.0, "roughness": 0.45, "bump": 0.05}
        smooth = True
    elif kind == "coin":
        m = trimesh.creation.cylinder(u(0.01, 0.014), 0.002, sections=32)
        m.apply_translation([0, 0, 0.001])
        mat = {"kind": "plain", "colours": [[0.8, 0.6, 0.3]] if u() < 0.5 else [[0.75, 0.75, 0.72]],
               "metallic": 1.0, "roughness": 0.3, "scale": 60.0}
        label, smooth = "coin", True
    elif kind == "card":
        m = trimesh.creation.box((0.086, 0.054, 0.0008))
        m.apply_translation([0, 0, 0.0004])
        mat = {"kind": "print", "colours": [_colour(rng), _colour(rng)], "scale": u(20, 60), "roughness": 0.3}
        label, smooth = "card", False
    elif kind == "toy":  # a figure: a rounded body and a head
        s = u(0.7, 1.3)
        body = trimesh.creation.capsule(height=0.05 * s, radius=0.025 * s, count=[16, 16])
        body.apply_translation([0, 0, 0.05 * s])
        head = trimesh.creation.icosphere(subdivisions=2, radius=0.022 * s)
        head.apply_translation([0, 0, 0.117 * s])
        m = trimesh.util.concatenate([body, head])
        m.apply_translation([0, 0, -m.bounds[0][2]])
        mat = {"kind": "plain", "colours": [_colour(rng, 0.2, 0.95)], "roughness": 0.35, "scale": 15.0}
        label, smooth = "toy", True
    else:
        raise ValueError(f"no object kind {kind!r}")
    lo, hi = m.bounds
    m.apply_translation([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]])  # base on z = 0, centred
    return {"label": label, "mesh": m, "material": mat, "smooth": smooth}


def _plant_in_pot(rng) -> list[dict]:
    """A pot and the plant growing from the soil in it: two objects, the plant's stems inside the pot."""
    u = rng.uniform
    r, h, w = u(0.045, 0.065), u(0.07, 0.1), 0.006
    pot = _revolve([[0, 0], [0.75 * r, 0], [r, h], [r - w, h], [0.75 * r - w, 0.008], [0, 0.008]])
    parts = []
    soil = h - 0.012
    for k in range(int(rng.integers(5, 9))):
        a = 2 * np.pi * k / 7 + u(-0.3, 0.3)
        tilt = u(0.35, 0.9)
        length = u(0.07, 0.13)
        leaf = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        leaf.vertices *= [length / 2, 0.018, 0.003]
        leaf.apply_translation([length / 2, 0, 0])
        leaf.apply_transform(trimesh.transformations.rotation_matrix(-tilt, [0, 1, 0]))  # rise outwards
        leaf.apply_transform(trimesh.transformations.rotation_matrix(a, [0, 0, 1]))
        leaf.apply_translation([0.01 * np.cos(a), 0.01 * np.sin(a), soil + 0.004])
        parts.append(leaf)
    stem = trimesh.creation.cylinder(0.004, 0.03, sections=8)
    stem.apply_translation([0, 0, soil + 0.015])
    plant = trimesh.util.concatenate(parts + [stem])
    green = [[0.08, u(0.25, 0.4), 0.05], [0.2, u(0.4, 0.5), 0.08]]
    return [{"label": "pot", "mesh": pot, "smooth": True,
             "material": {"kind": "mottled", "colours": [[0.55, 0.25, 0.12], [0.5, 0.22, 0.1]], "scale": 20.0,
                          "roughness": 0.8, "bump": 0.1}},
            {"label": "plant", "mesh": plant, "smooth": True,
             "material": {"kind": "mottled", "colours": green, "scale": 40.0, "roughness": 0.5}}]


KINDS = ("box", "book", "cup", "bowl", "bottle", "fruit", "coin", "card", "toy")


def _turned(mesh: trimesh.Trimesh, yaw: float, at) -> trimesh.Trimesh:
    m = mesh.copy()
    m.apply_transform(trimesh.transformations.rotation_matrix(yaw, [0, 0, 1]))
    m.apply_translation(at)
    return m


def _drop(mesh: trimesh.Trimesh, below: list[trimesh.Trimesh], clearance: float = 0.0005) -> float:
    """How far ``mesh`` can fall straight down before it meets any of ``below`` (metres), less ``clearance``:
    the smallest vertical gap between its vertices and the surfaces under them, and between theirs and its
    surface over them, so that a piled object rests on what holds it as the photo's truth says it does."""
    down, up = np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 1.0])
    gaps = [np.inf]
    for other in below:
        for source, target, direction in ((mesh, other, down), (other, mesh, up)):
            rays = np.repeat(direction[None], len(source.vertices), axis=0)
            hits, ray_ids, _ = target.ray.intersects_location(source.vertices, rays, multiple_hits=False)
            if len(hits):
                gaps.append(float(np.abs(hits[:, 2] - source.vertices[ray_ids, 2]).min()))
    gap = min(gaps)
    return max(0.0, gap - clearance) if np.isfinite(gap) else 0.0


def _group(rng) -> list[dict]:
    """One arrangement, its objects' meshes placed about the group's own origin (on the support, z = 0):
    a single object, a stack, a pile of fruit, a bowl of fruit, a coin on a card, a plant in its pot."""
    u = rng.uniform
    pick = rng.choice(["single", "single", "stack", "pile", "bowl", "coins", "plant", "cup_on_book"],
                      p=[0.2, 0.15, 0.17, 0.1, 0.1, 0.1, 0.08, 0.1])
    out = []
    if pick == "single":
        o = make_object(str(rng.choice(KINDS)), rng)
        o["mesh"] = _turned(o["mesh"], u(0, 2 * np.pi), [0, 0, 0])
        out.append(o)
    elif pick == "stack":  # boxes or books, each on the one below, smaller upwards, a little turned and shifted
        kind = str(rng.choice(["box", "book"]))
        z = 0.0
        for _ in range(int(rng.integers(2, 4))):
            o = make_object(kind, rng)
            ext = o["mesh"].extents
            m = o["mesh"]
            if out:  # never wider than what holds it
                below = out[-1]["mesh"].extents
                f = min(1.0, 0.85 * min(below[:2]) / max(ext[:2]))
                m.apply_scale([f, f, 1.0])
            at = [u(-0.01, 0.01), u(-0.01, 0.01), z]
            o["mesh"] = _turned(m, u(-0.3, 0.3), at)
            z = o["mesh"].bounds[1][2]
            if out:
                o["on_k"] = len(out) - 1
            out.append(o)
    elif pick == "pile":  # three fruit touching on the support and a fourth resting in their hollow
        r = u(0.03, 0.038)
        kind_rng = np.random.default_rng(int(rng.integers(1 << 31)))
        for k in range(4):
            o = make_object("fruit", kind_rng)
            o["mesh"] = _blob(rng, r, squash=1.0, bumps=0.015)
            if k < 3:
                a = 2 * np.pi * k / 3
                d = 2 * r * 1.04 / math.sqrt(3)
                at = [d * math.cos(a), d * math.sin(a), 0.0]
            else:
                at = [0, 0, 1.633 * r * 1.04 + 0.004]
                o["on_k"] = [0, 1, 2]  # in the hollow of the three: on each of them
            o["mesh"] = _turned(o["mesh"], u(0, 2 * np.pi), at)
            if k == 3:  # the sphere formula's height leaves a bumpy blob floating mm over the hollow: drop it in
                o["mesh"].apply_translation([0, 0, -_drop(o["mesh"], [p["mesh"] for p in out])])
            out.append(o)
    elif pick == "bowl":  # a bowl with a fruit lying on its floor
        bowl = make_object("bowl", rng)
        out.append(bowl)
        fruit = make_object("fruit", rng)
        inner = 0.55 * bowl["mesh"].extents[0] / 2 - 0.006
        f = min(1.0, inner / (fruit["mesh"].extents[0] / 2) * 1.6)
        fruit["mesh"].apply_scale(f)
        fruit["mesh"] = _turned(fruit["mesh"], 0.0, [0, 0, 0.007 + 0.001])
        fruit["on_k"] = 0
        out.append(fruit)
    elif pick == "coins":  # a card with a coin on it, and a coin beside it
        card = make_object("card", rng)
        card["mesh"] = _turned(card["mesh"], u(0, np.pi), [0, 0, 0])
        coin = make_object("coin", rng)
        coin["mesh"] = _turned(coin["mesh"], 0.0, [u(-0.015, 0.015), u(-0.01, 0.01), 0.0008])
        coin["on_k"] = 0
        other = make_object("coin", rng)
        other["mesh"] = _turned(other["mesh"], 0.0, [0.06, 0.05, 0])
        out += [card, coin, other]
    elif pick == "plant":
        yaw = u(0, 2 * np.pi)
        for o in _plant_in_pot(rng):
            o["mesh"] = _turned(o["mesh"], yaw, [0, 0, 0])
            if out:
                o["on_k"] = 0  # the plant grows in its pot
            out.append(o)
    else:  # a cup standing on a book
        book = make_object("book", rng)
        book["mesh"] = _turned(book["mesh"], u(0, np.pi), [0, 0, 0])
        cup = make_object("cup", rng)
        cup["mesh"] = _turned(cup["mesh"], u(0, 2 * np.pi), [u(-0.02, 0.02), u(-0.02, 0.02),
                                                               book["mesh"].bounds[1][2]])
        cup["on_k"] = 0
        out += [book, cup]
    return out


# --- the support, the room and the lights ---------------------------------------------------------------------

def _support_material(rng) -> dict:
    u = rng.uniform
    kind = str(rng.choice(["wood", "cloth", "paper", "board", "tiles"]))
    if kind == "wood":
        base = np.array([u(0.35, 0.6), u(0.2, 0.35), u(0.08, 0.15)])
        return {"kind": kind, "colours": [base.tolist(), (base * 0.6).tolist()], "scale": u(2, 6),
                "distortion": u(3, 9), "roughness": u(0.3, 0.6), "bump": 0.1}
    if kind == "cloth":
        return {"kind": kind, "colours": [_colour(rng, 0.1, 0.8), _colour(rng, 0.1, 0.8)], "scale": u(3, 12),
                "roughness": 0.9, "bump": 0.2}
    if kind == "paper":
        w = u(0.75, 0.92)
        return {"kind": kind, "colours": [[w, w, w * 0.97], [0.3, 0.4, 0.75]], "scale": u(25, 40),
                "roughness": 0.85, "bump": 0.05}
    if kind == "board":
        return {"kind": kind, "colours": [_colour(rng, 0.2, 0.9), _colour(rng, 0.05, 0.5)], "scale": u(4, 16),
                "roughness": 0.4}
    return {"kind": kind, "colours": [_colour(rng, 0.4, 0.9), [0.3, 0.3, 0.3]], "scale": u(3, 10),
            "offset": float(rng.choice([0.0, 0.5])), "roughness": 0.25, "bump": 0.3}


def _slab(lo, hi) -> trimesh.Trimesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(hi - lo)
    m.apply_translation((lo + hi) / 2)
    return m


def _light(rng, middle) -> dict:
    u = rng.uniform
    warm = u(-0.15, 0.15)  # colour temperature: + warm, − cool
    sky = np.array([0.6 - warm, 0.7, 0.8 + warm]) * u(0.6, 1.0)
    return {"sky": sky.tolist(), "sky_strength": u(0.2, 0.9),
            "sun_strength": u(1.0, 4.0), "sun_colour": [1.0, 1.0 - 0.3 * max(warm, 0), 1.0 - 0.6 * max(warm, 0)],
            "sun_angle_deg": u(1, 25), "sun_azimuth_deg": u(0, 360), "sun_elevation_deg": u(25, 80),
            "area_power": u(0, 120) if u() < 0.7 else 0.0, "area_size_m": u(0.3, 1.5),
            "area_colour": [1.0, 0.95, 0.9],
            "area_position": (np.asarray(middle) + [u(-1, 1), u(-1, 0.3), u(0.8, 1.6)]).tolist(),
            "area_target": list(map(float, middle))}


def _camera(rng, meshes, width: int, height: int, yaw: float, pitch_deg: float, fov_deg: float):
    """A level-rolled camera at ``pitch_deg`` and ``yaw`` (about the vertical; 0 looks along +Y) aimed at the
    objects' middle, as near as it can stand with every object inside the frame (a 6 % margin)."""
    lo = np.min([m.bounds[0] for m in meshes], axis=0)
    hi = np.max([m.bounds[1] for m in meshes], axis=0)
    target = 0.5 * (lo + hi)
    p, y = math.radians(pitch_deg), yaw
    forward = np.array([math.sin(y) * math.cos(p), math.cos(y) * math.cos(p), -math.sin(p)])
    right = np.array([math.cos(y), -math.sin(y), 0.0])
    down = np.cross(forward, right)
    axes = np.stack([right, down, forward], axis=1)
    pts = np.vstack([m.vertices for m in meshes])
    margin = 0.06 * np.array([width, height])
    distance = 0.15
    for _ in range(80):
        cam = PinholeCamera.from_pose(width, height, fov_deg, target - distance * forward, axes)
        uv, z = cam.project(pts)
        if z.min() > 0.05 and np.all(uv >= margin) and np.all(uv <= np.array([width, height]) - margin):
            break
        distance *= 1.08
    distance *= rng.uniform(1.0, 1.25)  # not always filling the frame
    return PinholeCamera.from_pose(width, height, fov_deg, target - distance * forward, axes)


def describe_scene(seed: int, width: int = SIZE[0], height: int = SIZE[1]) -> dict:
    """The scene of ``seed``: {"objects": [{label, mesh, material, smooth, place}], "surfaces": [...],
    "camera": PinholeCamera, "light": {...}, "layout": str}; the same seed draws the same scene.

    Groups stand apart on the support (their footprints do not meet); with a wall, one may stand on a shelf
    on it and one hang on it. Objects whose visible part is under :data:`MIN_VISIBLE_PX` are left out."""
    rng = np.random.default_rng(seed)
    u = rng.uniform
    layout = str(rng.choice(["table", "table", "wall"]))
    pitch = float(u(0.0, 90.0)) if layout == "table" else float(u(0.0, 45.0))
    fov = float(u(25.0, 80.0))
    yaw = float(u(-0.4, 0.4))
    groups, spots = [], []
    for _ in range(int(rng.integers(2, 4))):
        g = _group(rng)
        reach = max(np.linalg.norm(o["mesh"].bounds[:, :2], axis=1).max() for o in g)
        for tried in range(60):  # as near the others as it fits: a cluster, not a scatter
            at = rng.uniform(-1, 1, 2) * (0.03 + 0.01 * tried)
            if all(np.linalg.norm(at - s) > reach + r + 0.005 for s, r in spots):
                break
        else:
            continue
        spots.append((at, reach))
        for o in g:
            o["mesh"].apply_translation([at[0], at[1], 0.0])
            o["place"] = "support"
            k = o.pop("on_k", None)
            o["on"] = "support" if k is None else [g[j] for j in k] if isinstance(k, list) else g[k]
        groups.append(g)
    objects = [o for g in groups for o in g]
    surfaces = [{"name": "support", "mesh": _slab([-10, -10, -0.05], [10, 10, 0.0]),
                 "material": _support_material(rng), "smooth": False}]
    if layout == "wall":
        back = max(o["mesh"].bounds[1][1] for o in objects) + u(0.03, 0.2)
        wall_mat = ({"kind": "plain", "colours": [_colour(rng, 0.5, 0.95)], "roughness": 0.9, "scale": 3.0}
                    if u() < 0.6 else _support_material(rng))
        surfaces.append({"name": "wall", "mesh": _slab([-10, back, 0.0], [10, back + 0.05, 5.0]),
                         "material": wall_mat, "smooth": False})
        x = u(-0.15, 0.15)
        shelf_z = u(0.2, 0.35)
        depth = u(0.12, 0.2)
        wood = _support_material(np.random.default_rng(seed + 1))
        surfaces.append({"name": "shelf", "mesh": _slab([x - 0.15, back - depth, shelf_z - 0.02],
                                                        [x + 0.15, back, shelf_z]),
                         "material": wood if wood["kind"] == "wood" else {"kind": "plain", "colours": [[0.9] * 3],
                                                                          "roughness": 0.5}, "smooth": False})
        on = make_object(str(rng.choice(["box", "bottle", "cup", "toy", "bowl", "book"])), rng)
        on["mesh"] = _turned(on["mesh"], u(-0.4, 0.4),
                             [x + u(-0.06, 0.06), back - depth / 2, shelf_z])
        if on["mesh"].bounds[0][1] > back - depth and on["mesh"].bounds[1][1] < back:
            on["place"] = on["on"] = "shelf"
            objects.append(on)
        hung = make_object(str(rng.choice(["toy", "card"])), rng)
        m = hung["mesh"]
        if hung["label"] == "card":  # a card pinned upright
            m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
        side = rng.choice([-1, 1]) * (0.15 + m.extents[0] / 2 + u(0.02, 0.08))  # beside the shelf, not in it
        m.apply_translation([x + side - m.centroid[0], back - m.bounds[1][1],
                             u(0.15, 0.35) - m.bounds[0][2]])
        hung["place"] = hung["on"] = "wall"
        objects.append(hung)
    camera = _camera(rng, [o["mesh"] for o in objects], width, height, yaw, pitch, fov)
    # leave out what can hardly be seen (hidden behind others or a shelf): the others keep their places
    from ..geometry.raycast import SilhouetteRenderer

    while objects:
        meshes = [o["mesh"] for o in objects] + [s["mesh"] for s in surfaces]
        ids = SilhouetteRenderer([m.vertices for m in meshes], [m.faces for m in meshes]).render(camera)
        seen = [int((ids == i).sum()) for i in range(len(objects))]
        worst = int(np.argmin(seen))
        if seen[worst] >= MIN_VISIBLE_PX:
            break
        objects.pop(worst)
    names = {}
    for o in objects:
        names[o["label"]] = names.get(o["label"], 0) + 1
        o["name"] = f"{o['label']}{names[o['label']]}"
    for o in objects:  # what holds each: a surface's name, or the objects' ('hidden' when left out as unseen)
        held_by = o["on"] if isinstance(o["on"], list) else [o["on"]]
        if isinstance(held_by[0], dict):
            seen = [k["name"] for k in held_by if any(k is m for m in objects)]
            o["on"] = seen if isinstance(o["on"], list) and seen else seen[0] if seen else "hidden"
    middle = np.mean([o["mesh"].bounds.mean(0) for o in objects], axis=0) if objects else np.zeros(3)
    return {"seed": seed, "layout": layout, "objects": objects, "surfaces": surfaces, "camera": camera,
            "light": _light(rng, middle)}


def _mesh_json(item: dict) -> dict:
    m = item["mesh"]
    return {"name": item["name"], "vertices": np.round(m.vertices, 6).tolist(), "faces": m.faces.tolist(),
            "material": item["material"], "smooth": bool(item.get("smooth"))}


def render_scene(scene: dict, folder, samples: int = SAMPLES, threads: int = THREADS) -> dict:
    """Render ``scene`` (:func:`describe_scene`) with Cycles into ``folder``; returns the truth (also written as
    ``truth.json``) with the masks as arrays under ``modal`` and ``amodal``."""
    from ..geometry.raycast import SilhouetteRenderer

    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    cam = scene["camera"]
    spec = {"width": cam.width, "height": cam.height, "samples": samples, "threads": threads,
            "camera": {"position": cam.origin.tolist(), "world_from_camera": cam.world_from_camera.tolist(),
                       "fov_deg": cam.fov_deg},
            "light": scene["light"],
            "surfaces": [_mesh_json(s) for s in scene["surfaces"]],
            "objects": [_mesh_json(o) for o in scene["objects"]],
            "photo": str((folder / "photo.png").resolve()), "ids": str((folder / "ids.png").resolve())}
    spec_path = folder / "blender.json"
    spec_path.write_text(json.dumps(spec))
    script = pathlib.Path(__file__).with_name("blender_scene.py")
    t0 = time.perf_counter()
    proc = subprocess.run([blender_python(), str(script), str(spec_path)], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    line = next((x for x in proc.stdout.splitlines() if x.startswith("RESULT ")), None)
    if proc.returncode != 0 or line is None:
        tail = (proc.stderr.strip() or proc.stdout.strip()).splitlines()[-5:]
        raise RuntimeError(f"Blender failed on scene {scene['seed']}: " + " | ".join(tail))
    spec_path.unlink()
    ids = cv2.imread(str(folder / "ids.png"), cv2.IMREAD_COLOR)[..., 2].astype(int)  # red
    modal = [ids == ID_STEP * (k + 1) for k in range(len(scene["objects"]))]
    amodal = [SilhouetteRenderer([o["mesh"].vertices], [o["mesh"].faces]).render(cam) == 0
              for o in scene["objects"]]
    raycast = SilhouetteRenderer([o["mesh"].vertices for o in scene["objects"]] +
                                 [s["mesh"].vertices for s in scene["surfaces"]],
                                 [o["mesh"].faces for o in scene["objects"]] +
                                 [s["mesh"].faces for s in scene["surfaces"]]).render(cam)
    from ..metrics.image import mask_iou

    objects = []
    for k, (o, mm, am) in enumerate(zip(scene["objects"], modal, amodal)):
        cv2.imwrite(str(folder / f"modal_{k}.png"), mm.astype(np.uint8) * 255)
        cv2.imwrite(str(folder / f"amodal_{k}.png"), am.astype(np.uint8) * 255)
        o["mesh"].export(str(folder / f"mesh_{k}.ply"))
        m = o["mesh"]
        obb = m.bounding_box_oriented
        objects.append({"name": o["name"], "label": o["label"], "place": o["place"], "on": o["on"],
                        "modal": f"modal_{k}.png", "amodal": f"amodal_{k}.png", "mesh": f"mesh_{k}.ply",
                        "centre_m": m.bounds.mean(0).round(5).tolist(),
                        "pose": np.asarray(obb.primitive.transform).round(6).tolist(),
                        "size_m": np.asarray(obb.primitive.extents).round(5).tolist(),
                        "bounds_m": m.bounds.round(5).tolist(),
                        "longest_m": round(float(np.ptp(m.vertices, axis=0).max()), 5),
                        "visible_px": int(mm.sum()), "amodal_px": int(am.sum()),
                        # the id render against a ray cast of the same meshes: 1 when the two cameras agree
                        "id_render_iou": round(mask_iou(mm, raycast == k), 4)})
    truth = {"seed": scene["seed"], "layout": scene["layout"], "seconds_render": round(seconds, 2),
             "camera": {"width": cam.width, "height": cam.height, "fov_deg": cam.fov_deg,
                        "pitch_deg": cam.pitch_deg, "K": cam.K.tolist(), "position_m": cam.origin.tolist(),
                        "world_from_camera": cam.world_from_camera.tolist(),
                        "axes": "OpenCV (x right, y down, z forward); world Z up, the support at z = 0"},
            "objects": objects, "surfaces": [s["name"] for s in scene["surfaces"]]}
    (folder / "truth.json").write_text(json.dumps(truth, indent=1))
    return truth | {"modal": modal, "amodal": amodal}



def load_rendered(scene: dict, folder) -> dict | None:
    """The truth :func:`render_scene` wrote for ``scene`` into ``folder``, masks read back from its PNGs; None
    when the folder holds no complete render of this very scene (another seed, other objects, a file
    missing), so that the caller renders it."""
    folder = pathlib.Path(folder)
    try:
        truth = json.loads((folder / "truth.json").read_text())
    except (OSError, ValueError):
        return None
    names = [o["name"] for o in scene["objects"]]
    if truth.get("seed") != scene["seed"] or [o["name"] for o in truth.get("objects", [])] != names:
        return None
    if not (folder / "photo.png").is_file():
        return None
    modal, amodal = [], []
    for o in truth["objects"]:
        pair = [cv2.imread(str(folder / o[key]), cv2.IMREAD_GRAYSCALE) for key in ("modal", "amodal")]
        if any(m is None for m in pair):
            return None
        modal.append(pair[0] > 127)
        amodal.append(pair[1] > 127)
    return truth | {"modal": modal, "amodal": amodal}
