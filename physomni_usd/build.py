"""``build``: photo → ``scene.usda`` + ``physics.usda`` + ``shot.usda`` (+ an empty ``edits.usda``).

Runs perceive (masks, plate, lifting), align (camera, ground contact,
separation) and the default estimate (rigid materials from the label table).
All input is read and checked before anything is written.
"""

from __future__ import annotations

import pathlib
from dataclasses import dataclass

import cv2
import numpy as np

from ._files import write_bytes
from .align.camera import PinholeCamera, pick_pitch
from .align.camera_search import search_camera
from .align.external import load_poses, place_external
from .align.place import centring_offset, make_room, separate
from .backends import steps as backend_steps
from .errors import InputError
from .materials.defaults import GROUND_MATERIAL
from .materials.report import material_report
from .perceive.lift import fill_holes, foot_pixel, lift_silhouette
from .perceive.masks import read_photo
from .perceive.plate import object_texture
from .physics.forces import parse_force_options
from .physics.stability import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS
from .report import Timer, update_report
from .settings import BuildSettings
from .usd import layers
from .usd.author import (
    PhysicsObject,
    SceneObject,
    write_physics_layer,
    write_scene_layer,
)

TEXTURES = "textures"
INPUTS = "inputs"
#: Solver defaults written to the physics layer (the physics benchmark revisits them).
DEFAULT_SOLVER = "xpbd"


@dataclass
class BuildResult:
    folder: pathlib.Path
    shot: pathlib.Path
    objects: list[dict]
    seconds: dict


def prepare_output(folder) -> pathlib.Path:
    """The output folder, created if needed; refuses a path that is a file."""
    out = pathlib.Path(folder)
    if out.exists() and not out.is_dir():
        raise InputError(f"output {out} exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output directory {out}: {exc.strerror}") from None
    return out


def _object_name(option: str, spec: str, label: str, labels_to_names: dict[str, str]) -> str:
    name = labels_to_names.get(label.strip())
    if name is None:
        known = ", ".join(sorted(labels_to_names)) or "none"
        raise InputError(f"{option} {spec!r}: no object labelled {label.strip()!r} (known: {known})")
    return name


def parse_pushes(pushes, labels_to_names: dict[str, str]) -> dict[str, tuple[tuple[float, float, float], float]]:
    """``['cup=1,0,0@0.5']`` → ``{'cup_0': ((1, 0, 0), 0.5)}``; LABEL may be a label or a prim name.

    The velocity (m/s) is given to the object at the time after ``@`` (seconds, default 0).
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
        out[_object_name("--push", spec, label, labels_to_names)] = (v, at)
    return out


def parse_fixed(labels, labels_to_names: dict[str, str]) -> set[str]:
    """``--fix LABEL`` options → prim names of objects that must not move."""
    return {_object_name("--fix", label, label, labels_to_names) for label in labels or ()}


def build_shot(photo_path, out_dir, masks=(), boxes=(), settings: BuildSettings = BuildSettings(),
               pushes=(), echo=lambda msg: None, forces=(), fixed=(), meshes_dir=None, backends=None) -> BuildResult:
    """``backends``: kind → backend name for the swappable steps (see ``backends.steps.BUILD_KINDS``)."""
    timer = Timer()
    with timer.step("read"):
        chosen = backend_steps.resolve(backends, meshes_dir=meshes_dir)
        out = prepare_output(out_dir)
        photo = read_photo(photo_path)
        objects = backend_steps.collect_objects(photo, masks, boxes, chosen["segmenter"])
        settings, depth_info = backend_steps.apply_depth(chosen["depth"], photo, objects, settings)
        names = {}
        for o in objects:
            names.setdefault(o.label, o.name)
            names[o.name] = o.name
        push = parse_pushes(pushes, names)
        fields = parse_force_options(forces)
        fixed_names = parse_fixed(fixed, names)
    h, w = photo.shape[:2]
    echo(f"perceive: {len(objects)} object(s) in a {w}×{h} photo")

    with timer.step("perceive.plate"):
        plate = backend_steps.make_plate(photo, [o.mask for o in objects], settings.plate_dilation,
                                         chosen["inpainter"])

    if meshes_dir is None and backend_steps.lifts_in_camera(chosen["lifter"]):
        with timer.step("perceive.lift"):
            meshes_dir = backend_steps.lift_to_folder(chosen["lifter"], photo, objects, out / INPUTS / "lifted")

    if meshes_dir is not None:
        with timer.step("align.external"):
            placed = place_external(load_poses(meshes_dir, [o.label for o in objects]), w, h,
                                    settings.camera.fov_deg, settings.alignment,
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
        with timer.step("align.camera"):
            feet = [foot_pixel(fill_holes(o.mask))[1] for o in objects]
            pitch = pick_pitch(settings.camera.fov_deg, h, feet, settings.camera.pitch_deg)
            camera = PinholeCamera(w, h, settings.camera.fov_deg, pitch, (0.0, 0.0, settings.camera.height_m))
        with timer.step("perceive.lift"):
            lifted = [lift_silhouette(o.mask, camera, settings.lift) for o in objects]
        with timer.step("align.place"):
            projected, depth_scales = make_room([m.vertices for m in lifted], [m.contact for m in lifted],
                                                camera.origin, settings.gap_m)
            moves = separate(projected, settings.gap_m)
            verts = [v + d for v, d in zip(projected, moves)]
        faces, shapes = [m.faces for m in lifted], [m.shape for m in lifted]
        notes = [[] for _ in objects]
        align_info = {"variant": "silhouette", "depth_scales": [round(k, 4) for k in depth_scales],
                      "moved_apart_m": [round(float(np.linalg.norm(d)), 4) for d in moves]}
    centre = centring_offset(verts)
    verts = [v + centre for v in verts]
    projected = [v + centre for v in projected]
    camera = camera.moved(centre)

    with timer.step("perceive.texture"):
        import trimesh

        tex_dir = out / TEXTURES
        tex_dir.mkdir(exist_ok=True)
        scene_objects, report_objects = [], []
        for o, v, seen, f, shape, note in zip(objects, verts, projected, faces, shapes, notes):
            rgba, (x0, y0) = object_texture(photo, o.mask)
            # texture coordinates: the photo projected from the camera onto the object where it was seen
            uv, _ = camera.project(seen)
            st = np.stack([(uv[:, 0] - x0) / rgba.shape[1], 1.0 - (uv[:, 1] - y0) / rgba.shape[0]], 1)
            tm = trimesh.Trimesh(v, f, process=False)
            origin = tm.center_mass if tm.is_volume else v.mean(0)
            rel = f"{TEXTURES}/{o.name}.png"
            _write_png(out / rel, rgba)
            scene_objects.append(SceneObject(o.name, o.label, o.index, v - origin, f,
                                             np.asarray(tm.vertex_normals), st, origin, f"./{rel}", shape))
            report_objects.append({
                "name": o.name, "label": o.label, "mask_index": o.index, "source": o.source,
                "shape": shape, "pixels": int(o.mask.sum()), "size_m": np.ptp(v, axis=0).round(4).tolist(),
                "position_m": origin.round(4).tolist(), "watertight": bool(tm.is_watertight), "notes": note,
            })
        _write_png(out / TEXTURES / "plate.png", plate)
        # the inputs, so that later stages (estimate's crops) work from the shot folder alone
        (out / INPUTS / "masks").mkdir(parents=True, exist_ok=True)
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
        extent = max(np.abs(np.vstack(verts)[:, :2]).max() * 4.0, 20.0 * settings.camera.height_m)
        write_scene_layer(out / layers.SCENE, fps=settings.fps, image_size=(w, h), camera=camera,
                          plate=f"./{TEXTURES}/plate.png", objects=scene_objects, ground_size=float(extent),
                          extra={"physomni:photo": str(pathlib.Path(photo_path).name)})
        write_physics_layer(out / layers.PHYSICS, out / layers.SCENE, fps=settings.fps, objects=physics_objects,
                            ground=GROUND_MATERIAL, solver=DEFAULT_SOLVER, substeps=DEFAULT_SUBSTEPS,
                            iterations=DEFAULT_ITERATIONS, forces=fields)
        layers.reset_sim_layer(out, settings.fps)
        layers.ensure_edits_layer(out)
        shot = layers.write_shot_layer(out, settings.fps)
    echo("build: wrote " + ", ".join([layers.SCENE, layers.PHYSICS, layers.SHOT]))
    update_report(out, objects=report_objects, estimate=material_report(layers.open_shot(out), config.source), shot={"photo": str(photo_path), "width": w, "height": h,
                                                    "fov_deg": settings.camera.fov_deg,
                                                    "pitch_deg": round(camera.pitch_deg, 4), "alignment": align_info,
                                                    "camera_height_m": settings.camera.height_m,
                                                    "fps": settings.fps},
                  build={"seconds": timer.seconds, "total_seconds": timer.total,
                         "backends": backend_steps.report(chosen), **depth_info})
    return BuildResult(out, shot, report_objects, timer.seconds)


def _write_png(path: pathlib.Path, image: np.ndarray) -> None:
    """Write an RGB(A) image as PNG through a temporary file and a rename."""
    code = cv2.COLOR_RGBA2BGRA if image.shape[2] == 4 else cv2.COLOR_RGB2BGR
    ok, data = cv2.imencode(".png", cv2.cvtColor(image, code))
    if not ok:
        raise OSError(f"cannot encode {path.name}")
    write_bytes(path, data.tobytes())
