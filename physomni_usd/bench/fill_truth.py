"""The plate's fill against the truth: generated scenes rendered with their objects and without them.

``bench general``'s scenes (:func:`~.general.describe_scene`, rendered by Blender's Cycles) are drawn from a
seed and rendered twice: as the photo, and with every object taken out, which is the background the plate
should show. The plate is made from the photo and the objects' visible masks as ``build`` makes it (the
hole of :func:`~physomni_usd.texture.fill.plate_hole`, the build's dilation) by each fill method, and is held
against the empty render:

- ``error``: the mean absolute difference from the truth over the revealed area (where the objects stood:
  the union of their visible masks), levels 0-255 averaged over the three channels; ``error_hole`` the same
  over the whole hole (the objects, their widening, their contact shadows and the seam);
- ``error_local``: the same as ``error`` for the local colour (both images averaged with a Gaussian of
  σ = 4 px): the surface's grain cannot be predicted pixel by pixel, its colour and shading can;
- ``far``: how many revealed pixels lie farther than :data:`FAR_LEVELS` (Euclidean RGB distance, levels)
  from every colour of their surroundings (the known pixels within :data:`SURROUND` of the hole), and the
  largest such distance: a colour the world around the hole does not hold (a blue blob on a garage floor);
- ``floor``: the photo against the empty render outside the hole, which is how much the renders differ
  where nothing was taken out (path-tracing noise, light the objects bounced).

``python -m physomni_usd.bench.fill_truth --n 4 --seed 7`` prints one row per scene and method and the means;
it needs Blender's Python as ``bench general`` does (``PHYSOMNI_BLENDER_PYTHON``).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import tempfile
import time

import cv2
import numpy as np

from ..texture.pixels import SURROUND, nearest_surrounding

#: The fills compared: the plate's default (``texture/fill.py``), OpenCV's Telea, the blend (``texture/blend.py``,
#: the default before it) and the exemplar alone; ``floor`` (run only when named) is the default given the
#: scene's true camera, which fills the hole's part on the floor top-down (``texture/floor.py``).
METHODS = ("faded", "telea", "blend", "exemplar")
#: The fill the bench holds to the others: its error at most the better of these, and no revealed pixel farther
#: than :data:`FAR_LEVELS` from every colour of its surroundings.
HELD = "faded"
AGAINST = ("telea", "blend")
#: A revealed pixel farther than this from every colour of its surroundings is counted (RGB distance, levels).
FAR_LEVELS = 60.0
#: Width of the Gaussian over which the local colour is compared, pixels.
LOCAL_SIGMA = 4.0


def surroundings_distance(image: np.ndarray, hole: np.ndarray, reach: float | None = None) -> np.ndarray:
    """(H, W) float32: for each pixel of ``hole`` (H, W) bool, the RGB distance (levels) from its colour in
    ``image`` (H, W, 3) uint8 to the nearest colour among the known pixels (not ``hole``) within ``reach``
    pixels of its connected part of the hole (default :data:`SURROUND` of the diagonal); 0 outside the hole,
    inf for a part with no known pixel around it. The fill's colour cap measures the same way."""
    return nearest_surrounding(image, hole, reach)[1]


def score(plate: np.ndarray, truth: np.ndarray, revealed: np.ndarray, hole: np.ndarray) -> dict:
    """The numbers of one plate (H, W, 3) uint8 against the ``truth`` (the empty render): ``revealed`` and
    ``hole`` (H, W) bool as the module says."""
    a, b = plate.astype(np.float32), truth.astype(np.float32)
    diff = np.abs(a - b).mean(-1)
    blur = lambda x: cv2.GaussianBlur(x, (0, 0), LOCAL_SIGMA)  # noqa: E731
    local = np.abs(blur(a) - blur(b)).mean(-1)
    far = surroundings_distance(plate, hole)[revealed]
    return {"error": round(float(diff[revealed].mean()), 2), "error_hole": round(float(diff[hole].mean()), 2),
            "error_local": round(float(local[revealed].mean()), 2),
            "far": int((far > FAR_LEVELS).sum()), "far_max": round(float(far.max()) if far.size else 0.0, 1)}


def fill_rows(photo: np.ndarray, truth: np.ndarray, masks: list[np.ndarray], dilation: float,
              methods=METHODS, camera=None) -> dict:
    """Each of ``methods`` filling the objects ``masks`` (visible, (H, W) bool each) out of ``photo``, scored
    against ``truth``; also the hole's size and the renders' ``floor``. ``camera``: the scene's, for ``floor``."""
    from ..texture.fill import background_plate, plate_hole

    hole = plate_hole(photo, masks, dilation)
    revealed = np.any(masks, axis=0) & hole
    ring = ~hole & (cv2.distanceTransform((~hole).astype(np.uint8), cv2.DIST_L2, 5) <= 20)
    floor = np.abs(photo.astype(np.float32) - truth.astype(np.float32)).mean(-1)[ring]
    row = {"hole_px": int(hole.sum()), "revealed_px": int(revealed.sum()),
           "floor": round(float(floor.mean()) if floor.size else 0.0, 2), "methods": {}, "plates": {}}
    for method in methods:
        t0 = time.perf_counter()
        if method == "floor":
            plate = background_plate(photo, masks, dilation, method="faded", camera=camera)
        else:
            plate = background_plate(photo, masks, dilation, method=method)
        seconds = time.perf_counter() - t0
        row["methods"][method] = score(plate, truth, revealed, hole) | {"seconds": round(seconds, 2)}
        row["plates"][method] = plate
    return row


def render_pair(seed: int, folder) -> tuple[np.ndarray, np.ndarray, list[np.ndarray], dict]:
    """Scene ``seed`` of ``bench general`` rendered with its objects (``folder/scene``) and without them
    (``folder/empty``): the photo and the truth (H, W, 3) uint8 RGB, the visible masks and the scene's truth.
    A folder that holds both renders already is read, not rendered again."""
    from .general import describe_scene, render_scene

    folder = pathlib.Path(folder)
    read = lambda p: cv2.cvtColor(cv2.imread(str(p), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)  # noqa: E731
    done = folder / "scene" / "truth.json"
    if done.is_file() and (folder / "empty" / "truth.json").is_file():  # rendered before: score it again
        truth = json.loads(done.read_text())
        truth["modal"] = [cv2.imread(str(folder / "scene" / o["modal"]), cv2.IMREAD_GRAYSCALE) > 127
                          for o in truth["objects"]]
    else:
        scene = describe_scene(seed)
        if not scene["objects"]:
            return None, None, [], {}
        truth = render_scene(scene, folder / "scene")
        render_scene(dict(scene, objects=[]), folder / "empty")
    return read(folder / "scene" / "photo.png"), read(folder / "empty" / "photo.png"), truth["modal"], truth


def bench_fill_truth(n: int = 4, seed: int = 1, out_dir=None, methods=METHODS, echo=print) -> dict:
    """``n`` generated scenes from ``seed`` (scene seeds ``seed * 1000 + i``, as ``bench general`` draws them),
    each filled by every one of ``methods`` and scored; renders and plates go to ``out_dir`` (a temporary
    folder when None). Returns the rows and, per method, the means and in how many scenes its error is at
    most the better of the others'."""
    from ..geometry.camera import PinholeCamera
    from ..settings import BuildSettings

    dilation = BuildSettings().plate_dilation
    rows = []
    echo(f"{'scene':>8} {'layout':<6}{'hole':>7}{'floor':>7} | " + " | ".join(
        f"{m + ': err':>12}{'local':>7}{'hole':>7}{'far':>5}" for m in methods))
    with tempfile.TemporaryDirectory(prefix="physomni-fill-") as tmp:
        root = pathlib.Path(out_dir) if out_dir else pathlib.Path(tmp)
        for i in range(n):
            scene_seed = seed * 1000 + i
            photo, truth, masks, info = render_pair(scene_seed, root / f"scene_{i:03d}")
            if photo is None:
                echo(f"scene {scene_seed}: nothing visible was drawn; skipped")
                continue
            cam = info["camera"]
            camera = PinholeCamera.from_pose(cam["width"], cam["height"], cam["fov_deg"], cam["position_m"],
                                             cam["world_from_camera"])
            row = fill_rows(photo, truth, masks, dilation, methods, camera)
            for m, plate in row.pop("plates").items():
                cv2.imwrite(str(root / f"scene_{i:03d}" / f"plate_{m}.png"), cv2.cvtColor(plate, cv2.COLOR_RGB2BGR))
            row |= {"seed": scene_seed, "index": i, "layout": info["layout"], "objects_n": len(masks)}
            rows.append(row)
            echo(f"{scene_seed:>8} {row['layout']:<6}{row['hole_px']:>7}{row['floor']:>7.1f} | " + " | ".join(
                f"{row['methods'][m]['error']:>12.1f}{row['methods'][m]['error_local']:>7.1f}"
                f"{row['methods'][m]['error_hole']:>7.1f}{row['methods'][m]['far']:>5}" for m in methods))
    summary = {}
    for m in methods:
        others = [o for o in methods if o != m]
        summary[m] = {k: round(float(np.mean([r["methods"][m][k] for r in rows])), 2) if rows else None
                      for k in ("error", "error_local", "error_hole", "far", "seconds")}
        summary[m]["scenes_far"] = sum(r["methods"][m]["far"] > 0 for r in rows)
        summary[m]["at_most_the_best_other"] = sum(
            r["methods"][m]["error"] <= min(r["methods"][o]["error"] for o in others) for r in rows)
    for m, s in summary.items():
        echo(f"mean {m}: error {s['error']}, local {s['error_local']}, hole {s['error_hole']}, far pixels {s['far']} "
             f"(in {s['scenes_far']} of {len(rows)} scenes), {s['seconds']} s; error at most the best other's in "
             f"{s['at_most_the_best_other']} of {len(rows)}")
    numbers = {"seed": seed, "n": n, "dilation": dilation, "far_levels": FAR_LEVELS, "rows": rows, "summary": summary}
    if HELD in methods and set(AGAINST) <= set(methods):
        numbers["held"] = held = {"method": HELD, "against": list(AGAINST),
                                  "scenes": [r["seed"] for r in rows if holds(r)], "of": len(rows)}
        echo(f"{HELD}: error at most the better of {' and '.join(AGAINST)}'s and no revealed pixel farther than "
             f"{FAR_LEVELS:g} levels from its surroundings' colours in {len(held['scenes'])} of {len(rows)} scenes")
    return numbers


def holds(row: dict, held: str = HELD, against=AGAINST) -> bool:
    """Whether, in one scene's ``row`` (of :func:`fill_rows`), the fill ``held`` errs at most as much as the
    better of ``against`` in the revealed area and leaves no revealed pixel farther than :data:`FAR_LEVELS`
    from every colour of its surroundings."""
    m = row["methods"]
    return m[held]["error"] <= min(m[a]["error"] for a in against) and m[held]["far"] == 0


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=4, help="scenes (default 4)")
    parser.add_argument("--seed", type=int, default=1, help="the run's seed (default 1)")
    parser.add_argument("--out", default=None, help="folder for the renders and plates (default: a temporary one)")
    parser.add_argument("--json", default=None, help="write the numbers there")
    args = parser.parse_args(argv)
    numbers = bench_fill_truth(args.n, args.seed, args.out)
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(numbers, indent=1) + "\n")


if __name__ == "__main__":
    main()
