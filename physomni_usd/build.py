"""``build``: photo → ``scene.usda`` + ``physics.usda`` + ``shot.usda`` (+ an empty ``edits.usda``).

Runs perceive (masks, plate, lifting), align (camera, ground contact,
separation) and the default estimate (rigid materials from the label table).
All input is read and checked, and every file it will write is checked to be
writable, before anything is computed or written; a failed build puts the
folder back as it was (:func:`~physomni_usd._files.all_or_nothing`). A rebuild
removes what the previous build wrote that this one does not (textures and
masks of objects that are gone) and the video of the old shot, never other files.
"""

from __future__ import annotations

import json
import pathlib
from dataclasses import dataclass

import cv2
import numpy as np

from ._files import all_or_nothing, check_writable, make_dirs, remove_file, write_bytes
from .align.camera_search import search_camera
from .align.cues import DEFAULT_FOV_DEG
from .align.external import load_poses, place_external
from .align.photo_scene import build_photo_scene
from .align.place import centring_offset
from .align.scale import parse_sizes
from .backends import steps as backend_steps
from .errors import InputError
from .fields import parse_force_options
from .materials.defaults import GROUND_MATERIAL
from .materials.report import material_report
from .perceive.masks import contact_sheet, read_photo
from .perceive.plate import object_texture
from .perceive.sides import corner_st, two_sided_texture
from .physics.stability import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS
from .report import REPORT, Timer, read_report, set_aside_damaged, update_report
from .settings import BuildSettings
from .usd import layers
from .usd.author import (
    PhysicsObject,
    SceneObject,
    write_physics_layer,
    write_scene_layer,
)

TEXTURES = "textures"
VIDEO = "video.mp4"
INPUTS = "inputs"
#: The plate extended beyond the photo's frame (textures/), seen by camera moves.
WIDE_PLATE = "plate_wide.png"
#: The contact sheet of the masks over the photo, in the shot folder.
MASKS_SHEET = "masks.png"
#: Solver defaults written to the physics layer (the physics benchmark revisits them).
DEFAULT_SOLVER = "xpbd"


@dataclass
class BuildResult:
    folder: pathlib.Path
    shot: pathlib.Path
    objects: list[dict]
    seconds: dict


def prepare_output(folder) -> pathlib.Path:
    """The output folder, created if needed (and removed again if the command fails); refuses a path
    that is a file."""
    out = pathlib.Path(folder)
    if out.exists() and not out.is_dir():
        raise InputError(f"output {out} exists and is not a directory")
    try:
        make_dirs(out)
    except OSError as exc:
        raise InputError(f"cannot create output directory {out}: {exc.strerror}") from None
    return out


def _object_names(option: str, spec: str, label: str, labels_to_names: dict[str, list[str]]) -> list[str]:
    """Every object ``label`` names: a prim name names one, a label every object that has it."""
    names = labels_to_names.get(label.strip())
    if not names:
        known = ", ".join(sorted(labels_to_names)) or "none"
        raise InputError(f"{option} {spec!r}: no object labelled {label.strip()!r} (known: {known})")
    return names


def object_names(objects) -> dict[str, list[str]]:
    """Label or prim name → prim names of the objects it names (a label shared by several names them all)."""
    names: dict[str, list[str]] = {}
    for o in objects:
        names.setdefault(o.label, []).append(o.name)
    for o in objects:
        names[o.name] = [o.name]
    return names


def parse_pushes(pushes, labels_to_names: dict[str, list[str]],
                 echo=lambda m: None) -> dict[str, tuple[tuple[float, float, float], float]]:
    """``['cup=1,0,0@0.5']`` → ``{'cup_0': ((1, 0, 0), 0.5)}``; LABEL may be a label or a prim name.

    The velocity (m/s) is given to the object at the time after ``@`` (seconds, default 0). A label that
    several objects share pushes all of them (and says so); a prim name (``toy_1``) pushes one.
    """
    out = {}
    for spec in pushes or ():
        label, sep, vec = spec.partition("=")
        if not sep:
            raise InputError(f"--push {spec!r}: expected LABEL=VX,VY,VZ[@SECONDS]")
        vec, _, when = vec.partition("@")
        try:
            at = float(when) if when else 0.0
        except ValueError:
            at = float("nan")
        if not np.isfinite(at) or at < 0:
            raise InputError(f"--push {spec!r}: the time after @ must be a number of seconds ≥ 0")
        try:
            v = tuple(float(x) for x in vec.split(","))
        except ValueError:
            v = ()
        if len(v) != 3 or not all(np.isfinite(v)):
            raise InputError(f"--push {spec!r}: expected three finite numbers VX,VY,VZ in m/s")
        if max(abs(x) for x in v) > 1000:
            raise InputError(f"--push {spec!r}: speeds above 1000 m/s are not physical here")
        names = _object_names("--push", spec, label, labels_to_names)
        if len(names) > 1:
            echo(f"build: --push {label.strip()} pushes every object labelled {label.strip()!r}: "
                 f"{', '.join(names)} (name one prim, e.g. {names[0]}, to push only it)")
        for name in names:
            out[name] = (v, at)
    return out


def parse_fixed(labels, labels_to_names: dict[str, list[str]]) -> set[str]:
    """``--fix LABEL`` options → prim names of objects that must not move (every object with that label)."""
    return {n for label in labels or () for n in _object_names("--fix", label, label, labels_to_names)}


def _stale_files(out: pathlib.Path, written: set[str]) -> list[pathlib.Path]:
    """What the previous build (and render) of this folder wrote that this build does not write: textures
    and masks of objects that are gone, and the video of the old shot. Only files the old report lists
    (or, for shots from before it listed them, named after its objects) — never anything else."""
    old = read_report(out) or {}
    stages = old.get("stages", {})
    build = stages.get("build") if isinstance(stages.get("build"), dict) else {}
    files = {f for f in build.get("files") or () if isinstance(f, str)}
    for o in old.get("objects") or ():
        name = o.get("name") if isinstance(o, dict) else None
        if isinstance(name, str) and name:
            files |= {f"{TEXTURES}/{name}.png", f"{INPUTS}/masks/{name}.png"}
    # only PNGs of ours, whatever a hand-edited report says
    ours = [pathlib.PurePosixPath(f) for f in files - written]
    stale = [out / f for f in sorted(ours) if f.suffix == ".png" and len(f.parts) in (2, 3) and ".." not in f.parts
             and (f.parent == pathlib.PurePosixPath(TEXTURES) or f.parent == pathlib.PurePosixPath(INPUTS, "masks"))]
    render = stages.get("render")
    if isinstance(render, dict):
        stale.append(out / VIDEO)  # render's default output
        video = render.get("video")
        if isinstance(video, str) and video.endswith(".mp4"):
            v = pathlib.Path(video)
            v = v if v.is_absolute() else pathlib.Path.cwd() / v
            if v.resolve().parent == out.resolve():
                stale.append(out / v.name)
    return sorted({p for p in stale if p.is_file()})


def build_shot(photo_path, out_dir, masks=(), boxes=(), settings: BuildSettings = BuildSettings(),
               pushes=(), echo=lambda msg: None, forces=(), fixed=(), meshes_dir=None, sizes=(),
               backends=None) -> BuildResult:
    """``backends``: kind → backend name for the swappable steps (see ``backends.steps.BUILD_KINDS``)."""
    with all_or_nothing():
        return _build_shot(photo_path, out_dir, masks, boxes, settings, pushes, echo, forces, fixed, meshes_dir,
                           sizes, backends)


def _build_shot(photo_path, out_dir, masks, boxes, settings, pushes, echo, forces, fixed, meshes_dir,
                sizes, backends) -> BuildResult:
    timer = Timer()
    with timer.step("read"):
        chosen = backend_steps.resolve(backends, meshes_dir=meshes_dir)
        out = pathlib.Path(out_dir)
        if out.exists() and not out.is_dir():
            raise InputError(f"output {out} exists and is not a directory")
        photo = read_photo(photo_path, settings.max_pixels)
        objects = backend_steps.collect_objects(photo, masks, boxes, chosen["segmenter"])
        settings, depth_info = backend_steps.apply_depth(chosen["depth"], photo, objects, settings)
        names = object_names(objects)
        push = parse_pushes(pushes, names, echo)
        fields = parse_force_options(forces)
        fixed_names = parse_fixed(fixed, names)
        user_sizes = parse_sizes(sizes, [(o.name, o.label) for o in objects])
        files = {f"{TEXTURES}/{o.name}.png" for o in objects} | {f"{INPUTS}/masks/{o.name}.png" for o in objects}
        files |= {f"{TEXTURES}/plate.png", f"{TEXTURES}/{WIDE_PLATE}", f"{INPUTS}/photo.png"}
        targets = sorted(files) + [MASKS_SHEET, layers.SCENE, layers.PHYSICS, layers.SIM, layers.SHOT, layers.EDITS, REPORT]
        check_writable([out / f for f in targets])
        out = prepare_output(out)
        set_aside_damaged(out, echo)
    h, w = photo.shape[:2]
    echo(f"perceive: {len(objects)} object(s) in a {w}×{h} photo")
    for o in objects:
        if o.quality and o.quality.get("warning"):
            echo(f"warning: mask of {o.name}: {o.quality['warning']}")

    with timer.step("perceive.plate"):
        plate = backend_steps.make_plate(photo, [o.mask for o in objects], settings.plate_dilation,
                                         chosen["inpainter"])
    with timer.step("perceive.outpaint"):
        wide_plate, margins = backend_steps.make_wide_plate(plate, chosen["outpainter"])

    if meshes_dir is None and backend_steps.lifts_in_camera(chosen["lifter"]):
        with timer.step("perceive.lift"):
            meshes_dir = backend_steps.lift_to_folder(chosen["lifter"], photo, objects, out / INPUTS / "lifted")

    if meshes_dir is not None:
        with timer.step("align.external"):
            placed = place_external(load_poses(meshes_dir, [o.label for o in objects]), w, h,
                                    settings.camera.fov_deg or DEFAULT_FOV_DEG, settings.alignment,
                                    masks=[o.mask for o in objects])
        camera, faces, verts, projected = placed.camera, placed.faces, placed.vertices, placed.projected
        shapes = ["external"] * len(objects)
        notes = placed.info["mesh_notes"]
        align_info = placed.info
        if settings.camera_search:
            with timer.step("align.camera_search"):
                found = search_camera(camera, verts, faces, photo, [o.mask for o in objects], plate,
                                      max_evals=settings.camera_search_evals)
            camera = found.camera
            align_info["camera_search"] = {
                "loss": round(found.loss, 6), "initial_loss": round(found.initial_loss, 6),
                "evaluations": found.evaluations, "seconds": round(found.seconds, 3),
                "loss_curve": found.curve[:: max(1, len(found.curve) // 100)]}
    else:
        with timer.step("align.photo"):
            scene = build_photo_scene([o.mask for o in objects], [o.label for o in objects],
                                      [o.name for o in objects], photo, settings, user_sizes)
        camera, verts, projected, faces, shapes = (scene.camera, scene.vertices, scene.projected, scene.faces,
                                                   scene.shapes)
        notes = [[] for _ in objects]
        align_info = scene.info
    centre = centring_offset(verts)
    verts = [v + centre for v in verts]
    projected = [v + centre for v in projected]
    camera = camera.moved(centre)

    with timer.step("perceive.texture"):
        import trimesh

        make_dirs(out / TEXTURES)
        scene_objects, report_objects = [], []
        for o, v, seen, f, shape, note in zip(objects, verts, projected, faces, shapes, notes):
            rgba, (x0, y0) = object_texture(photo, o.mask)
            # texture coordinates: the photo projected from the camera onto the object where it was seen, and
            # a planar map for the sides it saw edge-on (perceive/sides.py)
            st = corner_st(seen, np.asarray(f), camera, (rgba.shape[1], rgba.shape[0]), (x0, y0))
            rgba = two_sided_texture(rgba)
            tm = trimesh.Trimesh(v, f, process=False)
            origin = tm.center_mass if tm.is_volume else v.mean(0)
            rel = f"{TEXTURES}/{o.name}.png"
            _write_png(out / rel, rgba)
            scene_objects.append(SceneObject(o.name, o.label, o.index, v - origin, f,
                                             np.asarray(tm.vertex_normals), st, origin, f"./{rel}", shape,
                                             texture_origin=(x0, y0), st_per_corner=True))
            report_objects.append({
                "name": o.name, "label": o.label, "mask_index": o.index, "source": o.source,
                "shape": shape, "pixels": int(o.mask.sum()), "size_m": np.ptp(v, axis=0).round(4).tolist(),
                "position_m": origin.round(4).tolist(), "watertight": bool(tm.is_watertight), "notes": note,
                "mask_quality": o.quality,
            })
        _write_png(out / TEXTURES / "plate.png", plate)
        _write_png(out / TEXTURES / WIDE_PLATE, wide_plate)
        _write_png(out / MASKS_SHEET, contact_sheet(photo, objects))
        # the inputs, so that later stages (estimate's crops) work from the shot folder alone
        make_dirs(out / INPUTS / "masks")
        _write_png(out / INPUTS / "photo.png", photo)
        for o in objects:
            _write_png(out / INPUTS / "masks" / f"{o.name}.png",
                       np.repeat(o.mask[..., None] * 255, 3, 2).astype(np.uint8))

    with timer.step("estimate"):
        config = chosen["estimator"].estimate(photo, [o.mask for o in objects], [o.label for o in objects],
                                               settings.fps)
        physics_objects = []
        for o, cfg in zip(objects, config.objects):
            velocity, at = push.get(o.name, (None, 0.0))
            physics_objects.append(PhysicsObject(
                o.name, cfg.material, cfg.params, config.source, velocity=velocity if at == 0 else None,
                fixed=o.name in fixed_names,
                delayed_velocity=(velocity, at) if velocity is not None and at > 0 else None))
        for o, rep in zip(objects, report_objects):
            if o.name in push:
                rep["push"] = {"velocity_m_s": list(push[o.name][0]), "at_s": push[o.name][1]}
            if o.name in fixed_names:
                rep["fixed"] = True

    with timer.step("write"):
        extent = max(np.abs(np.vstack(verts)[:, :2]).max() * 4.0, 20.0 * abs(float(camera.origin[2])))
        write_scene_layer(out / layers.SCENE, fps=settings.fps, image_size=(w, h), camera=camera,
                          plate=f"./{TEXTURES}/plate.png", objects=scene_objects, ground_size=float(extent),
                          extra={"physomni:photo": str(pathlib.Path(photo_path).name),
                                 **({"physomni:userSizes": {k: float(v) for k, v in user_sizes.items()}}
                                    if user_sizes else {})},
                          photo=f"./{INPUTS}/photo.png", wide_plate=(f"./{TEXTURES}/{WIDE_PLATE}", margins))
        write_physics_layer(out / layers.PHYSICS, out / layers.SCENE, fps=settings.fps, objects=physics_objects,
                            ground=GROUND_MATERIAL, solver=DEFAULT_SOLVER, substeps=DEFAULT_SUBSTEPS,
                            iterations=DEFAULT_ITERATIONS, forces=fields)
        layers.reset_sim_layer(out, settings.fps)
        layers.ensure_edits_layer(out, settings.fps)
        shot = layers.write_shot_layer(out, settings.fps)
        stale = _stale_files(out, files)
        for path in stale:
            remove_file(path)
    echo("build: wrote " + ", ".join([layers.SCENE, layers.PHYSICS, layers.SHOT]))
    if stale:
        echo("build: removed what the previous build made for the old shot: "
             + ", ".join(str(p.relative_to(out)) for p in stale))
    stage = layers.open_shot(out)
    layers.warn_orphan_overs(stage, out, echo)
    with timer.step("check"):
        from .physics.diagnose import scene_findings

        checks = [f.as_dict() for f in scene_findings(stage)]
    for c in checks:
        echo(f"check: {c['severity']}: {c['message']}")
    old = read_report(out) or {}
    for key in ("simulate", "render", "run"):  # they described the old shot
        old.get("stages", {}).pop(key, None)
    if old:
        write_bytes(out / REPORT, (json.dumps(old, indent=2) + "\n").encode())
    update_report(out, objects=report_objects, estimate=material_report(stage, config.source), shot={"photo": str(photo_path), "width": w, "height": h,
                                                    "fov_deg": round(camera.fov_deg, 4),
                                                    "pitch_deg": round(camera.pitch_deg, 4), "alignment": align_info,
                                                    "camera_height_m": round(float(camera.origin[2]), 4),
                                                    "scale": align_info.get("scale"),
                                                    "fps": settings.fps},
                  build={"seconds": timer.seconds, "total_seconds": timer.total, "files": sorted(files),
                         "checks": checks, "masks_sheet": MASKS_SHEET, "backends": backend_steps.report(chosen),
                         **depth_info})
    return BuildResult(out, shot, report_objects, timer.seconds)


def _write_png(path: pathlib.Path, image: np.ndarray) -> None:
    """Write an RGB(A) image as PNG through a temporary file and a rename."""
    code = cv2.COLOR_RGBA2BGRA if image.shape[2] == 4 else cv2.COLOR_RGB2BGR
    ok, data = cv2.imencode(".png", cv2.cvtColor(image, code))
    if not ok:
        raise OSError(f"cannot encode {path.name}")
    write_bytes(path, data.tobytes())
