"""``bench general``: scenes generated fresh from a seed, rendered photoreal with Blender's Cycles, with truth.

No scene is drawn twice (without ``--seed`` a new seed is drawn and printed), so nothing can be tuned for
them. The scenes are drawn and rendered by :mod:`.general_render` (re-exported here: ``describe_scene``,
``render_scene``); with ``-o`` a scene folder already rendered for the same seed is read back, not rendered
again.

:func:`scene_rows` builds a scene as a user would (``physomni_usd.build``, labels given) twice — from its
visible masks and from their bounding boxes — and measures each build:

- invariants (per scene): the build exits 0, ``simulate`` does not refuse it, no two meshes start deeper in
  each other than 2 mm, and with nothing pushed no rigid object moves more than 1 cm or turns more than 5°
  in 2 s;
- truth (per object): IoU of the built object as the shot shows it from the photo's camera (its mesh cut out
  by the mask its texture carries, as ``report.json``'s silhouette IoU; the bare mesh's beside it, a
  diagnostic) against the modal mask, of its whole
  silhouette against the amodal mask, and of its visible silhouette against the truth's from the camera
  orbited ±45° about the vertical through the objects' middle; position error over the true camera distance
  (after the one scale a photo cannot show, :func:`common_scale`, and before); the longest dimension over the
  truth's (as built); per scene the pitch error. Diagnostics beside them: the ±45° IoU of each object alone
  with its own position error taken out (:func:`shape_novel_iou`), and its size error too
  (:func:`sized_shape_novel_iou`: what a wrong field of view costs an object drawn right), and the split of its loss along the
  photo's ray through it, its error in depth, its extent in depth and the IoU with the depth error alone
  taken out (:func:`depth_split`).

The ±45° IoU is a strict measure of position for small things: an object a twentieth of the camera distance
across, 1 % of that distance off, is a fifth of its width off from the side, so the IoU ≥ 0.7 limit asks for
placement within about 1 % where the position limit asks for 5 %. ``--camera-given`` builds each scene told
the true pitch and field of view: what is left wrong then is the lift's and the placement's.
"""

from __future__ import annotations

import json
import os
import pathlib
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np
import trimesh

from ..geometry.camera import PinholeCamera
from .general_render import (  # noqa: F401 — the scene side, re-exported
    MIN_VISIBLE_PX, SAMPLES, SIZE, NoBlender, blender_python, describe_scene, load_rendered, render_scene)
from .limits import GENERAL

#: The limits the pass rates are counted against (the issue's acceptance).
LIMITS = {"start_overlap_m": 0.002, "rest_drift_m": 0.01, "rest_turn_deg": 5.0, "iou_photo": 0.85,
          "iou_novel": 0.7, "position_frac": 0.05, "size_factor": 1.5, "pitch_deg": 10.0,
          "frame0_psnr_db": 40.0}

# --- the bench: build each scene as a user would, then hold the build against the invariants and the truth ------

MODES = ("masks", "boxes")


def _specs(folder: pathlib.Path, truth: dict, mode: str) -> list[str]:
    """``--mask`` specs (the visible masks, labels given) or ``--box`` specs (their bounding boxes)."""
    out = []
    for o, m in zip(truth["objects"], truth["modal"]):
        if mode == "masks":
            out.append(f"{folder / o['modal']}:{o['label']}")
        else:
            ys, xs = np.nonzero(m)
            out.append(f"{xs.min()},{ys.min()},{xs.max() + 1},{ys.max() + 1}:{o['label']}")
    return out


def _silhouette_alone(mesh: trimesh.Trimesh, camera: PinholeCamera) -> np.ndarray:
    from ..geometry.raycast import SilhouetteRenderer

    return SilhouetteRenderer([mesh.vertices], [mesh.faces]).render(camera) == 0


def _in_truth_frame(mesh: trimesh.Trimesh, built_camera: PinholeCamera, camera: PinholeCamera, k: float) -> np.ndarray:
    """``mesh``'s vertices (built, seen by ``built_camera``) carried into the truth's frame at the one scale ``k``."""
    seen = (np.asarray(mesh.vertices) - built_camera.origin) @ built_camera.world_from_camera
    return camera.origin + (k * seen) @ camera.world_from_camera.T


def _novel_alone(world: np.ndarray, faces, true_mesh: trimesh.Trimesh, camera: PinholeCamera, centre) -> float:
    """The worse of the IoUs from ``camera`` orbited ±45° about ``centre`` of the mesh (``world``, ``faces``) and
    ``true_mesh``, each alone."""
    from ..metrics.image import mask_iou
    from .alignment import ORBIT_DEG, _orbit

    moved = trimesh.Trimesh(world, faces, process=False)
    return min(mask_iou(_silhouette_alone(moved, cam), _silhouette_alone(true_mesh, cam))
               for cam in (_orbit(camera, centre, a) for a in (-ORBIT_DEG, ORBIT_DEG)))


def shape_novel_iou(mesh: trimesh.Trimesh, true_mesh: trimesh.Trimesh, built_camera: PinholeCamera,
                    camera: PinholeCamera, k: float, centre) -> float:
    """The worse of the IoUs from the true camera orbited ±45° about ``centre`` of ``mesh`` (built, seen by
    ``built_camera``) and ``true_mesh``, each alone, with the built one carried into the truth's frame at the
    one scale ``k`` and moved so that its box centre is the truth's: its shape and size from the side, its
    position error (which ``iou_left``/``iou_right`` also count) taken out. A diagnostic, not a pass rate:
    where the ±45° IoU fails and this holds, the object is misplaced, not misshapen."""
    world = _in_truth_frame(mesh, built_camera, camera, k)
    world += 0.5 * (true_mesh.bounds[0] + true_mesh.bounds[1]) - 0.5 * (world.min(0) + world.max(0))
    return _novel_alone(world, mesh.faces, true_mesh, camera, centre)


def sized_shape_novel_iou(mesh: trimesh.Trimesh, true_mesh: trimesh.Trimesh, built_camera: PinholeCamera,
                          camera: PinholeCamera, k: float, centre) -> float:
    """:func:`shape_novel_iou` with the built object also scaled about its box centre until its extent across
    the true camera's ray through the truth is the truth's: its outline's size taken out, its depth kept. The
    one scale ``k`` fits the objects' positions, which a wrong field of view barely moves (they lie mostly
    along the rays) while it scales every outline across them by its tangent's error: an object that fills
    its photo outline exactly then comes out that much too small or large, and its shape score says so. Where
    this holds and :func:`shape_novel_iou` fails, the camera's field of view (or the object's own distance) is
    what is wrong, not the lift. (Sized by the whole box's diagonal, an object too deep along the ray was also
    shrunk across it, and its error in depth half hidden.)"""
    world = _in_truth_frame(mesh, built_camera, camera, k)
    middle = 0.5 * (world.min(0) + world.max(0))
    ray = 0.5 * (true_mesh.bounds[0] + true_mesh.bounds[1]) - np.asarray(camera.origin, float)
    ray = ray / max(float(np.linalg.norm(ray)), 1e-12)
    across = np.cross(ray, [0.0, 0.0, 1.0])
    if np.linalg.norm(across) < 1e-9:  # looking straight down: any horizontal pair is across the ray
        across = np.array([1.0, 0.0, 0.0])
    across = across / np.linalg.norm(across)
    axes = np.stack([across, np.cross(across, ray)], axis=1)

    def width(p):
        return float(np.linalg.norm(np.ptp(np.asarray(p, float) @ axes, axis=0)))

    grow = width(true_mesh.vertices) / max(width(world), 1e-12)
    world = 0.5 * (true_mesh.bounds[0] + true_mesh.bounds[1]) + grow * (world - middle)
    return _novel_alone(world, mesh.faces, true_mesh, camera, centre)


def depth_split(mesh: trimesh.Trimesh, true_mesh: trimesh.Trimesh, built_camera: PinholeCamera,
                camera: PinholeCamera, k: float, centre) -> dict:
    """Where the ±45° IoU is lost along the photo's ray through the object (what one photo shows least):
    ``depth_position`` (the built box centre's error along the true ray through the truth's, over the truth's
    longest side; > 0 farther than the truth), ``depth_extent`` (the built object's extent along that ray
    over the truth's), and ``iou_novel_depth_placed`` (the worse ±45° IoU alone, the depth-position error
    alone taken out: what placing it at the right depth would give, its shape as built). Beside
    ``iou_shape_novel`` (all the position error taken out) it splits an object's ±45° loss into placement
    in depth, placement across the photo (small where the photo's IoU is high) and shape."""
    world = _in_truth_frame(mesh, built_camera, camera, k)
    tc = 0.5 * (true_mesh.bounds[0] + true_mesh.bounds[1])
    ray = (tc - camera.origin) / max(float(np.linalg.norm(tc - camera.origin)), 1e-12)
    along = float((0.5 * (world.min(0) + world.max(0)) - tc) @ ray)
    extent = lambda v: float(np.ptp(np.asarray(v) @ ray))  # noqa: E731
    return {"depth_position": round(along / max(float(true_mesh.extents.max()), 1e-12), 4),
            "depth_extent": round(extent(world) / max(extent(true_mesh.vertices), 1e-12), 4),
            "iou_novel_depth_placed": round(_novel_alone(world - along * ray, mesh.faces, true_mesh, camera,
                                                         centre), 4)}


def _views_about(camera: PinholeCamera, meshes, centre) -> list[list[np.ndarray]]:
    """Visible masks of ``meshes`` from ``camera`` and from it orbited −45° and +45° about the vertical through
    ``centre`` (``bench alignment``'s views, about a point given)."""
    from ..align.external import visible_silhouettes
    from ..geometry.raycast import SilhouetteRenderer
    from .alignment import ORBIT_DEG, _orbit

    verts, faces = [m.vertices for m in meshes], [m.faces for m in meshes]
    renderer = SilhouetteRenderer(verts, faces)
    return [visible_silhouettes(verts, faces, _orbit(camera, centre, a) if a else camera, renderer)
            for a in (0.0, -ORBIT_DEG, ORBIT_DEG)]


def _shown(folder: pathlib.Path, names, meshes, camera: PinholeCamera) -> list[np.ndarray]:
    """Each built object as the shot shows it through ``camera`` (the photo's): its mesh cut out by the mask
    the build kept of it (``inputs/masks/NAME.png``), hidden where a nearer one is opaque."""
    import cv2

    from ..geometry.raycast import cut_out_silhouettes

    cuts = []
    for n in names:
        m = cv2.imread(str(folder / "inputs" / "masks" / f"{n}.png"), cv2.IMREAD_GRAYSCALE)
        if m.shape != (camera.height, camera.width):
            m = cv2.resize(m, (camera.width, camera.height), interpolation=cv2.INTER_NEAREST)
        cuts.append(m > 0)
    return cut_out_silhouettes([m.vertices for m in meshes], [m.faces for m in meshes], camera, cuts)


#: Where a build told some of the true camera (``camera_given``) goes, beside its mode's folder.
GIVEN_SUFFIX = {False: "", True: "-camera", "fov": "-fov"}


def given_camera(truth: dict, camera_given: bool | str):
    """The build settings that tell a build the truth's camera: its pitch and field of view (``True``), its
    field of view alone (``"fov"``: the pitch still read from the photo, under the right view), or nothing
    (``False``: None, the defaults). The field of view alone separates what a view the photo did not show
    costs (the cues' rows read as pitches under the default 50°, every ray turned) from what the pitch costs."""
    if not camera_given:
        return None
    from ..settings import BuildSettings

    if camera_given not in GIVEN_SUFFIX:
        raise ValueError(f"camera_given is True, False or 'fov', not {camera_given!r}")
    told = {"fov_deg": truth["camera"]["fov_deg"]}
    if camera_given is True:
        told["pitch_deg"] = truth["camera"]["pitch_deg"]
    settings = BuildSettings()
    return settings.model_copy(update={"camera": settings.camera.model_copy(update=told)})


def position_split(est: np.ndarray, true: np.ndarray) -> tuple[float, float]:
    """An object's position error ``est`` − ``true`` (both in the true camera's frame, after the one scale)
    split along the true ray through it (``depth``, > 0 farther than the truth) and across it (``lateral``,
    ≥ 0), each over its true distance. Across the ray is what the photo shows (a wrong field of view turns
    every ray but the centre's); along it is what the lift and the placement infer (the pitch, the support,
    the object's depth)."""
    dist = max(float(np.linalg.norm(true)), 1e-12)
    ray, err = true / dist, est - true
    along = float(err @ ray)
    return along / dist, float(np.linalg.norm(err - along * ray)) / dist


def build_row(folder, truth: dict, true_meshes: list, camera: PinholeCamera, mode: str,
              seconds: float = 2.0, materials: int = 0, camera_given: bool | str = False) -> dict:
    """One scene built from its masks or boxes (``mode``) into ``folder/mode``, simulated ``seconds`` with
    nothing pushed, against the invariants and the truth (see the module). ``camera_given``: the build is
    told the true pitch and field of view (``--pitch``, ``--fov``), into ``folder/mode-camera``, or with
    ``"fov"`` the field of view alone, into ``folder/mode-fov`` (:func:`given_camera`); what is left wrong
    is the lift's and the placement's (and with ``"fov"`` the pitch's), not the camera's."""
    import physomni_usd as api
    from pxr import Usd

    from ..metrics.geometry import rest_turn, world_meshes
    from ..metrics.image import mask_iou
    from ..usd import layers
    from .alignment import _built_camera, _middle
    from .photos import KnownScene, compare
    from .real_photos import rest_check

    folder = pathlib.Path(folder)
    labels = [o["label"] for o in truth["objects"]]
    row = {"seed": truth["seed"], "layout": truth["layout"], "mode": mode, "objects_n": len(labels),
           "pitch_true": round(truth["camera"]["pitch_deg"], 2), "fov_true": round(truth["camera"]["fov_deg"], 2),
           "built": False, "simulated": False, "error": None, "objects": [], "camera_given": camera_given}
    specs = _specs(folder, truth, mode)
    settings = given_camera(truth, camera_given)
    t0 = time.perf_counter()
    try:
        result = api.build(folder / "photo.png", folder / (mode + GIVEN_SUFFIX[camera_given]),
                           specs if mode == "masks" else (), specs if mode == "boxes" else (), settings)
    except BaseException as exc:  # noqa: BLE001 — a benchmark reports a failed build (even an exit) and goes on
        if isinstance(exc, KeyboardInterrupt):
            raise
        row |= {"error": f"build: {type(exc).__name__}: {exc}", "seconds_build": time.perf_counter() - t0}
        return _judge(row)
    row["seconds_build"] = round(time.perf_counter() - t0, 2)
    row["built"] = True
    report = json.loads((result.folder / "report.json").read_text())
    names = [o["name"] for o in report["objects"]]
    if len(names) != len(labels):
        row["error"] = f"build: {len(names)} objects built for {len(labels)} given"
        return _judge(row)
    known = KnownScene(None, truth["modal"], labels, true_meshes, camera, camera.pitch_deg)
    cmp = compare(known, result.folder)
    row |= {"pitch_deg": round(cmp["pitch_deg"], 2), "pitch_error_deg": round(cmp["pitch_error_deg"], 2),
            "fov_deg": round(cmp["fov_deg"], 2), "fov_error_frac": round(cmp["fov_error_frac"], 4),
            "scale_source": cmp["scale_source"]}
    stage = layers.open_shot(result.folder)
    built = world_meshes(stage, Usd.TimeCode(0).GetValue())
    mine = [built[n] for n in names]
    w, h = truth["camera"]["width"], truth["camera"]["height"]
    built_camera = _built_camera(stage, report["shot"]["fov_deg"], w, h)
    est_cam = np.array([(0.5 * (m.bounds[0] + m.bounds[1]) - built_camera.origin) @ built_camera.world_from_camera
                        for m in mine])
    true_cam = np.array([(0.5 * (m.bounds[0] + m.bounds[1]) - camera.origin) @ camera.world_from_camera
                         for m in true_meshes])
    k = common_scale(est_cam, true_cam)
    row["position_scale"] = round(k, 4)
    # the orbits turn about the truth's middle, and the build's about the same point of its camera's frame
    # (after the one scale): one misplaced object then spoils its own novel views, not everyone's
    middle = _middle(true_meshes)
    mapped = built_camera.origin + built_camera.world_from_camera @ (
        camera.world_from_camera.T @ (middle - camera.origin) / k)
    got = _views_about(built_camera, mine, mapped)
    # from the photo's camera, what the shot shows: each mesh cut out by the mask its texture carries (the
    # build's own, at the photo's size), the same measure as report.json's silhouette IoU
    shown = _shown(result.folder, names, mine, built_camera)
    from ..metrics.geometry import thin_side  # issue 38: no solid thinner than its outline allows

    row["thin"] = [n for n, m, lab in zip(names, mine, labels) if thin_side(m.vertices, lab, built_camera.origin)]
    row["frame0_psnr_db"] = frame0_psnr(stage, folder / "photo.png")
    want = _views_about(camera, true_meshes, middle)
    true_names = [o["name"] for o in truth["objects"]]
    for i, (name, label) in enumerate(zip(names, labels)):
        on = truth["objects"][i].get("on", "support")
        on_built = (report["objects"][i].get("start") or {}).get("support", "ground")
        o = cmp["objects"][label if labels.count(label) == 1 else name]
        ratio = o["longest_m"] / o["true_longest_m"]
        row["objects"].append({
            "name": name, "label": label, "place": truth["objects"][i]["place"],
            "on": on, "on_built": on_built, "support_ok": _support_ok(on, on_built, true_names, names),
            "iou_photo": round(mask_iou(shown[i], truth["modal"][i]), 4),
            "iou_photo_mesh": round(mask_iou(got[0][i], truth["modal"][i]), 4),
            "iou_amodal": round(mask_iou(_silhouette_alone(mine[i], built_camera), truth["amodal"][i]), 4),
            "iou_left": round(mask_iou(got[1][i], want[1][i]), 4),
            "iou_right": round(mask_iou(got[2][i], want[2][i]), 4),
            "iou_shape_novel": round(shape_novel_iou(mine[i], true_meshes[i], built_camera, camera, k, middle), 4),
            "iou_shape_novel_sized": round(sized_shape_novel_iou(mine[i], true_meshes[i], built_camera, camera, k,
                                                                 middle), 4),
            **depth_split(mine[i], true_meshes[i], built_camera, camera, k, middle),
            "position_error_frac": round(float(np.linalg.norm(k * est_cam[i] - true_cam[i])
                                               / np.linalg.norm(true_cam[i])), 4),
            **dict(zip(("position_depth_frac", "position_lateral_frac"),
                       (round(v, 4) for v in position_split(k * est_cam[i], true_cam[i])))),
            "raw_position_error_frac": round(o["raw_position_error_frac"], 4),
            "size_ratio": round(ratio, 3), "scaled_size_ratio": round(k * ratio, 3),
            "longest_m": o["longest_m"], "true_longest_m": o["true_longest_m"]})
    t1 = time.perf_counter()
    try:
        rest = rest_check(result.shot, seconds=seconds)
        turn = rest_turn(layers.open_shot(result.folder), names=set(rest["rigid"]))
        row |= {"simulated": True, "max_overlap_m": rest["max_overlap_m"], "max_drift_m": rest["max_drift_m"],
                "max_turn_deg": round(max(turn.values(), default=0.0), 2), "drift_m": rest["drift_m"],
                "turn_deg": {n: round(v, 2) for n, v in turn.items()}, "overlap_m": rest["overlap_m"]}
    except Exception as exc:  # noqa: BLE001 — simulate refusing the built scene is what this counts
        row["error"] = f"simulate: {type(exc).__name__}: {exc}"
    row["seconds_simulate"] = round(time.perf_counter() - t1, 2)
    if materials:  # a sample of the objects, drawn from the scene's seed: the same objects on a rerun
        pick = np.random.default_rng(truth["seed"]).permutation(len(names))[:materials]
        row["materials"] = material_trials(result.folder, [names[i] for i in sorted(pick)])
    return _judge(row)


def common_scale(est_cam: np.ndarray, true_cam: np.ndarray) -> float:
    """The one scale a photo cannot show, taking the built objects' box centres ``est_cam`` (k, 3; in the built
    camera's frame) to the truth's ``true_cam`` (in the true camera's): the median over objects of the ratio of
    their distances from the camera.

    Why the median and not a least-squares fit of the positions (``bench photos``' ``position_scale``): least
    squares in metres is ruled by the farthest, worst-placed object. A toy hung on a wall 1.8 m off, built on
    the ground 3.2 m off, drew the fit to 0.82 while eight fruits were built 2-11 % farther than they
    are; after that scale every fruit was 9-16 % off and, the novel views being orbited about a point
    mapped with it, none overlapped its truth from ±45° (IoU 0.00 for all ten objects of scene 504846001; with
    the median, 0.97, the fruits' worse-of-±45° IoUs are 0.00-0.67 and the toys' stay 0.00). The median is the
    scale most of the scene agrees on, so a misplaced object fails its own position and novel views, not
    everyone's. It still fails a scene whose objects disagree with one another (a wrong depth order, a pitch
    that stretches depth, an object off the ground) and, as built, a scene of the wrong size (``size``)."""
    ratio = np.linalg.norm(true_cam, axis=1) / np.maximum(np.linalg.norm(est_cam, axis=1), 1e-9)
    return float(np.exp(np.median(np.log(ratio))))


def _support_ok(on: str, built: str, true_names: list[str], names: list[str]) -> bool:
    """Whether the build stands an object on what holds it in the truth: the ground on the support, the object
    it rests on on that object (or one of several), anything but the ground on a shelf, a wall or an object left
    out as unseen."""
    if on == "support":
        return built == "ground"
    if isinstance(on, list):  # in the hollow of several: on any of them
        return built in [names[true_names.index(k)] for k in on if k in true_names]
    if on in true_names:
        return built == names[true_names.index(on)]
    return built != "ground"


def frame0_psnr(stage, photo_path) -> float:
    """PSNR (dB) of the shot's frame 0, composed before encoding, against the photo (issue 39: frame 0 is the
    photo whatever the lift); 99 where they are equal to the bit (cv2 gives 361 for an exact copy)."""
    import cv2

    from ..rendering.video import ShotRenderer

    frame = ShotRenderer(stage).frame(float(stage.GetStartTimeCode()))
    photo = cv2.cvtColor(cv2.imread(str(photo_path)), cv2.COLOR_BGR2RGB)
    if frame.shape != photo.shape:
        return 0.0
    return round(min(float(cv2.PSNR(frame, photo)), 99.0), 2)


def _non_finite(stage) -> list[str]:
    """Paths of the time-sampled numeric attributes of ``stage`` with a value that is not finite."""
    from pxr import Usd

    bad = []
    for prim in stage.Traverse():
        for a in prim.GetAttributes():
            for t in a.GetTimeSamples():
                try:
                    value = np.asarray(a.Get(Usd.TimeCode(t)), float)
                except (TypeError, ValueError):  # a token (visibility) or a string: nothing to overflow
                    break
                if not np.isfinite(value).all():
                    bad.append(a.GetPath().pathString)
                    break
    return bad


#: The materials every object must simulate as (issue 38: rigid is the build's own, checked at rest above).
MATERIALS = ("mpm_elastic", "mpm_sand", "pbd_cloth")


#: Longest a material trial may take before it counts as stopped, seconds (they take 0.5-3 min here).
MATERIAL_LIMIT_S = 600.0


def _material_trial(shot_folder, name: str, kind: str, seconds: float) -> dict:
    """One trial of :func:`material_trials` on the shot in ``shot_folder`` (changed in place: a copy)."""
    import physomni_usd as api

    from ..settings import SimulateSettings
    from ..usd import layers

    folder = pathlib.Path(shot_folder)
    try:
        api.estimate(folder / layers.SHOT, sets=[f"{name}.material={kind}"])
        api.simulate(folder / layers.SHOT, SimulateSettings(seconds=seconds))
        bad = _non_finite(layers.open_shot(folder))
        return {"ok": not bad, "error": f"non-finite values in {bad[0]}" if bad else None}
    except Exception as exc:  # noqa: BLE001 — a stop is what this counts
        return {"ok": False, "error": f"{type(exc).__name__}: {exc}"}


def material_trials(shot_folder, names, seconds: float = 1.0, limit_s: float = MATERIAL_LIMIT_S) -> list[dict]:
    """Each of ``names`` switched in turn to each of :data:`MATERIALS` (``estimate --set NAME.material=KIND``)
    on a copy of the built shot, simulated ``seconds``: ``ok`` when simulate finishes within ``limit_s`` (no
    guard stop, no endless refinement) and every value it wrote is finite. Each trial runs in a process of
    its own, so that one that does not end can be stopped."""
    import shutil

    code = ("import json, sys\nfrom physomni_usd.bench.general import _material_trial\n"
            "print('RESULT ' + json.dumps(_material_trial(sys.argv[1], sys.argv[2], sys.argv[3], "
            "float(sys.argv[4]))))")
    out = []
    for name in names:
        for kind in MATERIALS:
            with tempfile.TemporaryDirectory(prefix="physomni-material-") as tmp:
                copy = pathlib.Path(tmp) / "shot"
                shutil.copytree(shot_folder, copy)
                t0 = time.perf_counter()
                trial = {"object": name, "material": kind}
                try:
                    proc = subprocess.run([sys.executable, "-c", code, str(copy), name, kind, str(seconds)],
                                          capture_output=True, text=True, timeout=limit_s)
                    line = next((x for x in proc.stdout.splitlines() if x.startswith("RESULT ")), None)
                    trial |= (json.loads(line[len("RESULT "):]) if line else
                              {"ok": False, "error": (proc.stderr.strip().splitlines() or ["no output"])[-1]})
                except subprocess.TimeoutExpired:
                    trial |= {"ok": False, "error": f"{seconds:g} s not simulated in {limit_s:g} s"}
                trial["seconds"] = round(time.perf_counter() - t0, 1)
                out.append(trial)
    return out


def _judge(row: dict) -> dict:
    """The row's invariants (True / False) and whether it meets them all."""
    lim = LIMITS
    sim = row["simulated"]
    row["invariants"] = {
        "builds": row["built"] and not (row["error"] or "").startswith("build"),
        "simulates": sim,
        "start_overlap": sim and row["max_overlap_m"] <= lim["start_overlap_m"],
        "rest_drift": sim and row["max_drift_m"] <= lim["rest_drift_m"],
        "rest_turn": sim and row["max_turn_deg"] <= lim["rest_turn_deg"],
        "thickness": row["built"] and "thin" in row and not row["thin"]}
    if "materials" in row:
        row["invariants"]["every_material"] = all(t["ok"] for t in row["materials"])
    row["all_invariants"] = all(row["invariants"].values())
    for o in row["objects"]:
        o["passes"] = {"iou_photo": o["iou_photo"] >= lim["iou_photo"],
                       "iou_amodal": o["iou_amodal"] >= lim["iou_photo"],
                       "iou_novel": min(o["iou_left"], o["iou_right"]) >= lim["iou_novel"],
                       "position": o["position_error_frac"] <= lim["position_frac"],
                       "support": o.get("support_ok", True),
                       "size": max(o["size_ratio"], 1 / o["size_ratio"]) <= lim["size_factor"]}
    return row


INVARIANTS = ("builds", "simulates", "start_overlap", "rest_drift", "rest_turn", "thickness")
TRUTHS = ("iou_photo", "iou_amodal", "iou_novel", "position", "size", "support")


def summarise(rows: list[dict]) -> dict:
    """Per mode: the fraction of scenes meeting each invariant (and all of them) and the pitch limit, the
    fraction of objects meeting each truth limit (an object of a failed build fails them all), and medians."""
    out = {}
    for mode in dict.fromkeys(r["mode"] for r in rows):
        group = [r for r in rows if r["mode"] == mode]
        n = len(group)
        objects_n = sum(r["objects_n"] for r in group)
        objs = [o for r in group for o in r["objects"]]
        s = {"scenes": n, "objects": objects_n}
        for key in INVARIANTS + ("every_material",):
            judged = [r["invariants"][key] for r in group if key in r["invariants"]]
            if judged or key != "every_material":
                s[key] = round(sum(judged) / n, 3)
        trials = [t for r in group for t in r.get("materials", [])]
        if trials:
            s["material_trials"] = {k: f"{sum(t['ok'] for t in trials if t['material'] == k)}/"
                                       f"{sum(t['material'] == k for t in trials)}" for k in MATERIALS}
        s["all_invariants"] = round(sum(r["all_invariants"] for r in group) / n, 3)
        s["pitch"] = round(sum(r.get("pitch_error_deg", 1e9) <= LIMITS["pitch_deg"] for r in group) / n, 3)
        s["frame0"] = round(sum(r.get("frame0_psnr_db", 0.0) >= LIMITS["frame0_psnr_db"] for r in group) / n, 3)
        for key in TRUTHS:
            s[key] = round(sum(o["passes"][key] for o in objs) / max(objects_n, 1), 3)
        med = lambda vals: round(float(np.median(vals)), 4) if vals else None  # noqa: E731
        s["median"] = {"iou_photo": med([o["iou_photo"] for o in objs]),
                       "iou_photo_mesh": med([o["iou_photo_mesh"] for o in objs if "iou_photo_mesh" in o]),
                       "iou_amodal": med([o["iou_amodal"] for o in objs]),
                       "iou_novel": med([min(o["iou_left"], o["iou_right"]) for o in objs]),
                       "iou_shape_novel": med([o["iou_shape_novel"] for o in objs if "iou_shape_novel" in o]),
                       "iou_shape_novel_sized": med([o["iou_shape_novel_sized"] for o in objs
                                                     if "iou_shape_novel_sized" in o]),
                       "iou_novel_depth_placed": med([o["iou_novel_depth_placed"] for o in objs
                                                      if "iou_novel_depth_placed" in o]),
                       "depth_position_abs": med([abs(o["depth_position"]) for o in objs if "depth_position" in o]),
                       "depth_extent": med([o["depth_extent"] for o in objs if "depth_extent" in o]),
                       "position_error_frac": med([o["position_error_frac"] for o in objs]),
                       "position_depth_abs": med([abs(o["position_depth_frac"]) for o in objs
                                                  if "position_depth_frac" in o]),
                       "position_lateral": med([o["position_lateral_frac"] for o in objs
                                                if "position_lateral_frac" in o]),
                       "raw_position_error_frac": med([o["raw_position_error_frac"] for o in objs]),
                       "size_ratio": med([o["size_ratio"] for o in objs]),
                       "pitch_error_deg": med([r["pitch_error_deg"] for r in group if "pitch_error_deg" in r]),
                       "fov_error_frac": med([r["fov_error_frac"] for r in group if "fov_error_frac" in r]),
                       "frame0_psnr_db": med([r["frame0_psnr_db"] for r in group if "frame0_psnr_db" in r])}
        out[mode] = s
    return out


def scene_rows(index: int, seed: int, folder, modes=MODES, seconds: float = 2.0, echo=print,
               materials: int = 0, camera_given: bool | str = False) -> list[dict]:
    """Scene ``index`` of the run of ``seed``: generate, render, build by each of ``modes``; a row per mode."""
    from ..geometry.raycast import SilhouetteRenderer  # noqa: F401 — warp loads once, before the clock starts

    scene_seed = seed * 1000 + index
    folder = pathlib.Path(folder)
    t0 = time.perf_counter()
    scene = describe_scene(scene_seed)
    if not scene["objects"]:
        echo(f"scene {scene_seed}: nothing visible was drawn; skipped")
        return []
    truth = load_rendered(scene, folder)  # a scene kept by an earlier run with ``-o``: not rendered again
    if truth is None:
        truth = render_scene(scene, folder)
    for o, drawn in zip(truth["objects"], scene["objects"]):  # a render kept from before truth said what holds it
        o.setdefault("on", drawn["on"])
    rows = []
    for mode in modes:
        row = build_row(folder, truth, [o["mesh"] for o in scene["objects"]], scene["camera"], mode, seconds,
                        materials if mode == modes[0] else 0, camera_given)
        row["scene"] = index
        row["seconds_render"] = truth["seconds_render"]
        rows.append(row)
        echo(_line(row))
    for r in rows:
        r["seconds_scene"] = round(time.perf_counter() - t0, 1)
    return rows


def _line(r: dict) -> str:
    mm = lambda key: "—" if key not in r else f"{1000 * r[key]:.1f}"  # noqa: E731
    objs = r["objects"]
    iou = f"{np.median([o['iou_photo'] for o in objs]):.2f}" if objs else "—"
    nov = f"{np.median([min(o['iou_left'], o['iou_right']) for o in objs]):.2f}" if objs else "—"
    pos = f"{100 * max(o['position_error_frac'] for o in objs):.1f}" if objs else "—"
    size = f"{max(max(o['size_ratio'], 1 / o['size_ratio']) for o in objs):.2f}" if objs else "—"
    pitch = f"{r['pitch_deg']:.0f}/{r['pitch_true']:.0f}" if "pitch_deg" in r else f"—/{r['pitch_true']:.0f}"
    turn = "—" if "max_turn_deg" not in r else f"{r['max_turn_deg']:.1f}"
    f0 = "—" if "frame0_psnr_db" not in r else f"{r['frame0_psnr_db']:.0f}"
    failed = [k for k, v in r["invariants"].items() if not v]
    return (f"{r['seed']:>10} {r['layout']:<7}{r['mode']:<6}{r['objects_n']:>3}{pitch:>8}{mm('max_overlap_m'):>8}"
            f"{mm('max_drift_m'):>8}{turn:>7}{iou:>6}{nov:>6}{pos:>7}{size:>7}{f0:>6}"
            f"{r.get('seconds_build', 0):>8.1f}  " + ("ok" if not failed else "FAIL " + ",".join(failed))
            + (f"  ({r['error']})" if r["error"] else ""))


HEADER = (f"{'scene':>10} {'layout':<7}{'from':<6}{'n':>3}{'pitch':>8}{'ovl mm':>8}{'drift mm':>8}{'turn°':>7}"
          f"{'IoU':>6}{'±45°':>6}{'pos%':>7}{'size×':>7}{'f0 dB':>6}{'build s':>8}  invariants")


def bench_general(n: int, seed: int | None = None, out_dir=None, modes=MODES, seconds: float = 2.0,
                  echo=print, materials: int = 0, camera_given: bool | str = False) -> dict:
    """``n`` scenes drawn from ``seed`` (a new one, printed, when None), each built by every one of ``modes``
    (told the true camera with ``camera_given``: see :func:`build_row`); the scenes and shots go to
    ``out_dir`` (a temporary folder, removed, when None). Returns the numbers."""
    GENERAL.check(n=n, seed=seed, seconds=seconds, materials=materials)  # before any work, as the command does
    blender_python()  # no Blender: say so before drawing anything
    if seed is None:
        seed = int(np.random.default_rng().integers(1, 1_000_000))
    echo(f"bench general: seed {seed} ({n} scenes; rerun them with --seed {seed})"
         + {False: "", True: "; each build is given the true pitch and field of view",
            "fov": "; each build is given the true field of view"}[camera_given])
    started = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix="physomni-general-") as tmp:
        root = pathlib.Path(out_dir) if out_dir else pathlib.Path(tmp)
        echo(HEADER)
        for i in range(n):
            rows += scene_rows(i, seed, root / f"scene_{i:03d}", modes, seconds, echo, materials, camera_given)
    summary = summarise(rows) if rows else {}
    numbers = {"seed": seed, "n": n, "camera_given": camera_given, "date": time.strftime("%Y-%m-%d"),
               "machine": f"{platform.machine()}, {os.cpu_count()} cores", "size": list(SIZE), "samples": SAMPLES,
               "limits": LIMITS, "summary": summary, "rows": rows,
               "seconds_total": round(time.perf_counter() - started, 1),
               "seconds_per_scene": round((time.perf_counter() - started) / max(n, 1), 1)}
    for line in markdown(numbers).splitlines():
        echo(line)
    return numbers


def markdown(numbers: dict) -> str:
    """The pass rates as a Markdown table, one column per build mode."""
    s = numbers["summary"]
    modes = list(s)
    given = {True: " --camera-given", "fov": " --fov-given"}.get(numbers.get("camera_given"), "")
    lines = [f"`bench general --n {numbers['n']} --seed {numbers['seed']}{given}` on {numbers['date']} "
             f"({numbers['machine']}), {numbers['size'][0]}×{numbers['size'][1]} px, {numbers['samples']} samples: "
             f"{numbers['seconds_per_scene']} s per scene (render, {len(modes)} builds and their simulations).", "",
             "| pass rate | " + " | ".join(f"from {m}" for m in modes) + " |",
             "|---|" + "---:|" * len(modes)]
    names = {"builds": "scenes: build exits 0", "simulates": "scenes: simulate does not refuse",
             "start_overlap": f"scenes: start overlap ≤ {1000 * LIMITS['start_overlap_m']:g} mm",
             "rest_drift": f"scenes: unpushed, nothing moves > {100 * LIMITS['rest_drift_m']:g} cm in 2 s",
             "rest_turn": f"scenes: unpushed, nothing turns > {LIMITS['rest_turn_deg']:g}° in 2 s",
             "thickness": "scenes: no solid thinner than a third of its outline (unless flat)",
             "every_material": "scenes: sampled objects simulate 1 s as every material",
             "all_invariants": "**scenes: every invariant**",
             "pitch": f"scenes: pitch within {LIMITS['pitch_deg']:g}°",
             "frame0": f"scenes: frame 0 against the photo ≥ {LIMITS['frame0_psnr_db']:g} dB PSNR",
             "iou_photo": f"objects: IoU ≥ {LIMITS['iou_photo']} against the visible mask",
             "iou_amodal": f"objects: IoU ≥ {LIMITS['iou_photo']} against the whole outline",
             "iou_novel": f"objects: IoU ≥ {LIMITS['iou_novel']} from ±45°",
             "position": f"objects: position error ≤ {100 * LIMITS['position_frac']:g} % of camera distance",
             "size": f"objects: longest dimension within {LIMITS['size_factor']}×",
             "support": "objects: standing on what holds them in the truth (ground, object, shelf or wall)"}
    for key, name in names.items():
        if any(key in s[m] for m in modes):
            lines.append(f"| {name} | " + " | ".join("—" if key not in s[m] else f"{100 * s[m][key]:.0f} %"
                                                     for m in modes) + " |")
    lines.append("| scenes / objects | " + " | ".join(f"{s[m]['scenes']} / {s[m]['objects']}" for m in modes) + " |")
    meds = {"iou_photo": "median IoU, visible mask",
            "iou_photo_mesh": "median IoU, visible mask, the bare meshes (concavities filled, not cut out)",
            "iou_amodal": "median IoU, whole outline",
            "iou_novel": "median IoU, worse of ±45°",
            "iou_shape_novel": "median IoU, worse of ±45°, alone, own position error taken out",
            "iou_shape_novel_sized": "median IoU, worse of ±45°, alone, own position and size error taken out",
            "iou_novel_depth_placed": "median IoU, worse of ±45°, alone, own error along its ray taken out",
            "depth_position_abs": "median error along its ray, over its longest side",
            "depth_extent": "median extent along its ray over the truth's",
            "position_error_frac": "median position error (after scale)",
            "position_depth_abs": "median position error along the photo's ray (after scale)",
            "position_lateral": "median position error across the photo's ray (after scale)",
            "raw_position_error_frac": "median position error (as built)", "size_ratio": "median size ratio",
            "pitch_error_deg": "median pitch error °", "fov_error_frac": "median field-of-view error",
            "frame0_psnr_db": "median frame 0 PSNR dB"}
    def cell(value, key):
        if value is None:
            return "—"
        return (f"{100 * value:.1f} %" if "position_error" in key or key.startswith("position_") or "fov" in key
                else f"{value:.2f}")

    for key, name in meds.items():
        lines.append(f"| {name} | " + " | ".join(cell(s[m]["median"].get(key), key) for m in modes) + " |")
    return "\n".join(lines) + "\n"
