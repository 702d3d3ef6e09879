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
from dataclasses import dataclass, field

import cv2
import numpy as np

from ._files import all_or_nothing, check_writable, make_dirs, remove_file, write_bytes
from .align.camera_search import search_camera
from .align.cues import DEFAULT_FOV_DEG
from .align.external import place_external, posed_entries
from .align.photo_scene import place_on_ground
from .align.place import centring_offset
from .align.scale import parse_sizes
from .align.solve import solve_places
from .align.support import start_contacts
from .backends import steps as backend_steps
from .backends.builtin import BuiltinInpainter, MeshFolderLifter
from .errors import InputError
from .fields import parse_force_options
from .geometry.depth import ground_pitch
from .materials.defaults import GROUND_MATERIAL
from .materials.report import material_report
from .perceive.amodal import complete
from .perceive.masks import check_labels, check_photo_size, contact_sheet, qualify_among, read_photo
from .perceive.working import working
from .physics.stability import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS
from .report import REPORT, Timer, read_report, set_aside_damaged, update_report
from .settings import BuildSettings
from .texture.carry import FILL_PIXELS, carry_plate
from .texture.hidden import believed, occlusion_kept, painted_part
from .texture.objects import at_photo_size, texture_object
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
        from .suggest import did_you_mean

        known = ", ".join(sorted(labels_to_names)) or "none"
        raise InputError(f"{option} {spec!r}: no object labelled {label.strip()!r}"
                         f"{did_you_mean(label, labels_to_names)} (known: {known})")
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
               backends=None, find=None, finder=None) -> BuildResult:
    """``backends``: kind → backend name for the swappable steps (see ``backends.steps.BUILD_KINDS``);
    ``find``: phrases ('cup, saucer') whose every instance the ``finder`` backend finds (default sam3)."""
    with all_or_nothing():  # the inputs are checked first thing in it, before any work or write
        return _build_shot(photo_path, out_dir, masks, boxes, settings, pushes, echo, forces, fixed, meshes_dir,
                           sizes, backends, find, finder)


def check_build_inputs(photo_path, masks, boxes, settings: BuildSettings) -> None:
    """Refuse (InputError, before any work) more masks and boxes than ``settings.max_objects`` and a photo
    over ``settings.max_pixels``, judged from its header."""
    count = len(masks) + len(boxes)
    if count > settings.max_objects:
        raise InputError(f"--mask/--box: {count} objects; a shot has at most {settings.max_objects}")
    check_photo_size(photo_path, settings.max_pixels)


@dataclass
class ShotObject:
    """One object as the stages fill it in: the mask (segment), the mesh and pose (lift), where it stands
    (place) and its texture (texture)."""

    mask: object  # perceive.masks.ObjectMask
    amodal: np.ndarray | None = None  # (H, W) bool: the mask completed behind what hides it (complete)
    occluders: list = field(default_factory=list)  # indices of the objects that hide part of it
    completion: str = "whole"  # how the hidden part was closed (perceive.amodal.Completion.how)
    lifted: object = None  # swappable.protocols.LiftedObject
    vertices: np.ndarray | None = None  # (N, 3) world metres, placed
    projected: np.ndarray | None = None  # (N, 3) world metres, where the photo saw it (texture coordinates)
    faces: np.ndarray | None = None
    shape: str = ""
    notes: list = field(default_factory=list)
    report: dict = field(default_factory=dict)
    rest: dict = field(default_factory=dict)  # what it stands on and how far from it (align.support)
    full_mask: np.ndarray | None = None  # (H, W) bool: a mask file at the photo's size, beside its working copy

    @property
    def name(self) -> str:
        return self.mask.name


@dataclass
class Scene:
    """The shot being built: what every stage reads and fills, in stage order."""

    photo: np.ndarray
    settings: BuildSettings
    objects: list[ShotObject]
    backends: dict
    plate: np.ndarray | None = None
    wide_plate: np.ndarray | None = None
    margins: tuple = ()
    camera: object = None  # geometry.camera.PinholeCamera
    align_info: dict = field(default_factory=dict)
    scene_objects: list = field(default_factory=list)  # usd.author.SceneObject, by the texture stage
    config: object = None  # materials.config.SceneConfig, by the estimate stage
    physics_objects: list = field(default_factory=list)  # usd.author.PhysicsObject, by the estimate stage
    kept: dict = field(default_factory=dict)  # (object, occluder) indices → occlusion_kept, once placed
    # a photo above the working resolution (perceive.working): ``photo`` is its working copy, ``full_photo``
    # the photo itself (what the plate, the textures and frame 0 show); ``small_plate``: the plate of the reduced
    # copy ``plate`` was carried up from (see _plate), None where the photo itself was filled
    work: object = None
    full_photo: np.ndarray | None = None
    small_plate: np.ndarray | None = None

    @property
    def masks(self) -> list[np.ndarray]:
        return [o.mask.mask for o in self.objects]


def _build_shot(photo_path, out_dir, masks, boxes, settings, pushes, echo, forces, fixed, meshes_dir,
                sizes, backends, find=None, finder=None) -> BuildResult:
    from .backends.finders import find_objects, load_finder

    check_build_inputs(photo_path, masks, boxes, settings)
    timer = Timer()
    with timer.step("read"):
        chosen = backend_steps.resolve(backends, meshes_dir=meshes_dir)
        finding = load_finder(find, finder)
        lifter = chosen["lifter"] if meshes_dir is None else MeshFolderLifter(meshes_dir)
        out = pathlib.Path(out_dir)
        if out.exists() and not out.is_dir():
            raise InputError(f"output {out} exists and is not a directory")
        check_labels(masks, boxes)
        full_photo = photo = read_photo(photo_path, settings.max_pixels)
        settings = _view_from_exif(photo_path, full_photo.shape, settings, echo)
        work = working(photo.shape, settings.working_pixels)
        full_masks = []
        if work is not None:
            photo = work.down(full_photo)
            objects, full_masks = (backend_steps.collect_working(work, photo, masks, boxes, chosen["segmenter"],
                                                                 _box_progress(echo))
                                   if masks or boxes or finding is None else ([], []))
        else:
            objects = (backend_steps.collect_objects(photo, masks, boxes, chosen["segmenter"], _box_progress(echo))
                       if masks or boxes or finding is None else [])
        if finding is not None:
            objects += find_objects(photo, find, finding, len(objects), echo)
        qualify_among(photo, objects)  # a mask's warning that the objects in front of it explain is not given
        depth_info = {}
        if chosen["depth"] is not None:  # the ground the depth model sees gives the pitch, unless --pitch did
            found = ground_pitch(chosen["depth"].depth(photo), settings.camera.fov_deg or DEFAULT_FOV_DEG,
                                 ~np.any([o.mask for o in objects], axis=0))
            depth_info = {"depth_ground": found}
            if found is not None and settings.camera.pitch_deg is None:
                seen = {"pitch_deg": float(np.clip(found["pitch_deg"], 0.0, 90.0))}
                settings = settings.model_copy(update={"camera": settings.camera.model_copy(update=seen)})
        names = object_names(objects)
        push = parse_pushes(pushes, names, echo)
        fields = parse_force_options(forces)
        fixed_names = parse_fixed(fixed, names)
        user_sizes = parse_sizes(sizes, [(o.name, o.label) for o in objects])
        files = {f"{TEXTURES}/{o.name}.png" for o in objects} | {f"{INPUTS}/masks/{o.name}.png" for o in objects}
        files |= {f"{TEXTURES}/plate.png", f"{TEXTURES}/{WIDE_PLATE}", f"{INPUTS}/photo.png"}
        targets = sorted(files) + [MASKS_SHEET, layers.SCENE, layers.PHYSICS, layers.SIM, layers.SHOT, layers.EDITS, REPORT]
        check_writable([out / f for f in targets], inside=out)  # textures/, inputs/masks/ too
        out = prepare_output(out)
        set_aside_damaged(out, echo)
    h, w = full_photo.shape[:2]
    echo(f"perceive: {len(objects)} object(s) in a {w}×{h} photo"
         + (f", worked on at {work.work[1]}×{work.work[0]}" if work is not None else ""))
    for o in objects:
        if o.quality and o.quality.get("warning"):
            echo(f"warning: mask of {o.name}: {o.quality['warning']}")
    scene = Scene(photo, settings, [ShotObject(o) for o in objects], chosen, work=work, full_photo=full_photo)
    for o, m in zip(scene.objects, full_masks):
        o.full_mask = m

    with timer.step("perceive.complete"):
        _complete(scene)
    with timer.step("lift"):  # the built-in lifter also measures the ground and the camera (align.photo_scene)
        _lift(scene, lifter, user_sizes, out)
    echo("texture: filling the background plate behind the objects")
    with timer.step("texture.plate"):
        _plate(scene)
    echo("texture: widening the plate beyond the photo's frame (for camera moves)")
    with timer.step("texture.outpaint"):
        _outpaint(scene)
    with timer.step("align.place"):
        _place(scene)
    echo(_camera_line(scene))
    for warning in ((scene.align_info.get("camera") or {}).get("warnings", [])
                    + (scene.align_info.get("scale") or {}).get("warnings", [])
                    + scene.align_info.get("silhouette_warnings", [])):
        echo(f"warning: {warning}")
    with timer.step("texture.objects"):
        _texture(scene, out, photo_path)
    with timer.step("estimate"):
        _estimate(scene, push, fixed_names)
    with timer.step("write"):
        shot, stale = _write(scene, out, photo_path, user_sizes, fields, files)
    echo("build: wrote " + ", ".join([layers.SCENE, layers.PHYSICS, layers.SHOT]))
    if stale:
        echo("build: removed what the previous build made for the old shot: "
             + ", ".join(str(p.relative_to(out)) for p in stale))
    if settings.settle_s > 0:
        with timer.step("settle"):
            _settle(scene, out, photo_path, user_sizes, fields, files, echo)
    stage = layers.open_shot(out)
    layers.warn_orphan_overs(stage, out, echo)
    with timer.step("check"):
        from .physics.diagnose import scene_findings

        checks = [f.as_dict() for f in scene_findings(stage)]
        for c in checks:
            if c["severity"] != "error":
                echo(f"check: {c['severity']}: {c['message']}")
        _refuse_what_simulate_refuses(out)
    old = read_report(out) or {}
    for key in ("simulate", "render", "run"):  # they described the old shot
        old.get("stages", {}).pop(key, None)
    if old:
        write_bytes(out / REPORT, (json.dumps(old, indent=2) + "\n").encode())
    camera, align_info = scene.camera, scene.align_info
    occlusion = _occlusion_report(scene)
    report_objects = [o.report for o in scene.objects]
    update_report(out, objects=report_objects, estimate=material_report(stage, scene.config.source),
                  shot={"photo": str(photo_path), "width": w, "height": h,
                        **({"working_size": [work.work[1], work.work[0]]} if work is not None else {}),
                        "fov_deg": round(camera.fov_deg, 4),
                        "pitch_deg": round(camera.pitch_deg, 4), "alignment": align_info,
                        "camera_height_m": round(float(camera.origin[2]), 4),
                        "scale": align_info.get("scale"),
                        "fps": settings.fps},
                  build={"seconds": timer.seconds, "cpu_seconds": timer.cpu_seconds,
                         "total_seconds": timer.total, "files": sorted(files),
                         "checks": checks, "masks_sheet": MASKS_SHEET, "backends": backend_steps.report(chosen),
                         **({"occlusion": occlusion} if occlusion else {}),
                         **depth_info})
    return BuildResult(out, shot, report_objects, timer.seconds)


def _view_from_exif(photo_path, shape, settings: BuildSettings, echo) -> BuildSettings:
    """``settings`` with the field of view the photo's EXIF gives (and its source) where --fov gave none; a
    view outside --fov's range is said and left to the cues."""
    from .perceive.exif import exif_view
    from .settings import CameraSettings

    if settings.camera.fov_deg is not None:
        return settings
    bounds = {k: getattr(m, k) for m in CameraSettings.model_fields["fov_deg"].metadata
              for k in ("gt", "lt") if getattr(m, k, None) is not None}
    seen = exif_view(photo_path, shape[1], shape[0], (bounds["gt"], bounds["lt"]))
    if seen is None:
        return settings
    if seen.fov_deg is None:
        echo(f"warning: {seen.warning}")
        return settings
    return settings.model_copy(update={"camera": settings.camera.model_copy(
        update={"fov_deg": seen.fov_deg, "fov_source": seen.source})})


def _camera_line(scene: Scene) -> str:
    """The camera build chose and what chose it (the report's shot.alignment.camera says it in full)."""
    searched = ", then the camera search" if "camera_search" in scene.align_info else ""
    info = scene.align_info.get("camera") or {"pitch_source": "placed meshes" + searched,
                                              "fov_source": scene.align_info.get("fov_source", "") + searched}
    return (f"align: camera pitched {scene.camera.pitch_deg:.1f}° ({info.get('pitch_source')}), field of view "
            f"{scene.camera.fov_deg:.1f}° ({info.get('fov_source')})")


def _refuse_what_simulate_refuses(out: pathlib.Path) -> None:
    """End the build (exit 1, one line naming the object or pair and why; the folder put back as it was) where
    ``simulate`` would refuse the shot just written: the very checks it makes before it starts
    (``physics.prepare.refuse_unsimulatable``), on the stage as it composes it."""
    from .errors import PhysOmniError
    from .physics.diagnose import SceneRefused
    from .physics.prepare import refuse_unsimulatable

    try:
        refuse_unsimulatable(layers.open_shot(out, mute_sim=True), name=str(out / layers.SHOT))
    except SceneRefused as exc:
        found = exc.finding
        # the separation pass measures as the check does: an overlap left is a bug, not the photo
        why = {"penetration": " after the separation pass",
               "size": " (give its size with --size LABEL=METRES, or correct its label)"}.get(found.check, "")
        why = "" if "--size gave" in found.message else why
        raise PhysOmniError(f"{found.message}{why}: simulate would refuse the scene") from None
    except PhysOmniError as exc:
        raise PhysOmniError(f"{exc}: simulate would refuse the scene") from None


def _plate(scene: Scene) -> None:
    """The background plate behind the objects; the built-in inpainter's, for a photo above
    :data:`~.texture.carry.FILL_PIXELS` (or the working size), filled on a copy reduced to that size and carried
    to the photo's size (``texture.carry.carry_plate``); a plugin's, on the working copy as the objects were.
    Where the lifter measured the ground, its camera goes with the photo: the floor's part of the hole is filled
    top-down (``texture.floor``, which scales the camera to the size it is given)."""
    ground = scene.objects[0].lifted.ground if scene.objects and scene.objects[0].lifted is not None else None
    camera = ground.camera if ground is not None else None
    photo = scene.photo if scene.full_photo is None else scene.full_photo
    if isinstance(scene.backends["inpainter"], BuiltinInpainter):
        # never finer than the working copy: a photo at or under FILL_PIXELS is still carried up from it
        fill = working(photo.shape, min(FILL_PIXELS, scene.settings.working_pixels))
    else:  # a plugin gives no sources: carried up from a reduced copy its fill would be an upsampled blur
        fill = scene.work
    if fill is None:  # the photo is at or under the working size: scene.photo is the photo
        scene.plate = backend_steps.make_plate(scene.photo, scene.masks, scene.settings.plate_dilation,
                                               scene.backends["inpainter"], camera=camera)
        return
    # the masks taken to the fill's size; a fill pixel is in the hole where any of it is an object's, so a part
    # narrower than a fill pixel (a wire) is still filled, not left in the plate
    masks = [cv2.resize(m.astype(np.uint8) * 255, (fill.work[1], fill.work[0]), interpolation=cv2.INTER_AREA) > 0
             for m in scene.masks]
    small = fill.down(photo)
    sources = np.full(small.shape[:2] + (2,), -1, np.int32)
    weight = np.full(small.shape[:2], -1.0, np.float32)  # stays -1 where the inpainter does not write it
    scene.small_plate = backend_steps.make_plate(small, masks, scene.settings.plate_dilation,
                                                 scene.backends["inpainter"], sources, camera, weight)
    scene.plate = carry_plate(photo, fill, small, scene.small_plate,
                              sources if (sources[..., 0] >= 0).any() else None,
                              weight if (weight >= 0).all() else None)


def _outpaint(scene: Scene) -> None:
    """The plate widened for camera moves: at the fill's reduced size for a larger photo (seen only as the camera
    moves, at the render's size; its margins alone are 3× the photo's pixels)."""
    plate = scene.plate if scene.small_plate is None else scene.small_plate
    scene.wide_plate, scene.margins = backend_steps.make_wide_plate(plate, scene.backends["outpainter"])


def _complete(scene: Scene) -> None:
    """Who hides whom, and each hidden object's outline completed behind its occluders."""
    for o, c in zip(scene.objects, complete(scene.masks)):
        o.amodal, o.occluders, o.completion = c.amodal, c.occluders, c.how


def _box_progress(echo):
    """``progress(done, total)`` for the boxes' masks: one line each once there are several, since each box
    runs GrabCut (seconds on a large photo) before anything else is said."""
    def progress(done: int, total: int) -> None:
        if total > 1:
            echo(f"perceive: mask {done}/{total} cut from its box")
    return progress


def _lift(scene: Scene, lifter, user_sizes: dict, out: pathlib.Path) -> None:
    """Every object's mesh and pose from the lifter, built-in or plugin alike, from the completed outlines;
    a model's are kept in the shot."""
    lifted = backend_steps.lift(lifter, scene.photo, [o.mask for o in scene.objects], scene.settings, user_sizes,
                                masks=[o.amodal for o in scene.objects])
    if lifted[0].ground is None and not isinstance(lifter, MeshFolderLifter):
        backend_steps.record_lifted(lifted, [o.mask for o in scene.objects], out / INPUTS / "lifted")
    for o, m in zip(scene.objects, lifted):
        o.lifted = m


def _place(scene: Scene) -> None:
    """All objects in one world: on the ground the lifter measured, or on the ground fitted to posed meshes;
    then solved together against their outlines (``align.solve``), and centred on the origin."""
    lifted = [o.lifted for o in scene.objects]
    settings = scene.settings
    if lifted[0].ground is not None:
        placed = place_on_ground(lifted, [o.name for o in scene.objects], settings.gap_m)
        camera, verts, projected, faces, shapes = (placed.camera, placed.vertices, placed.projected,
                                                   placed.faces, placed.shapes)
        notes = [list(m.notes) for m in lifted]
        align_info = placed.info
    else:
        h, w = scene.photo.shape[:2]
        placed = place_external(posed_entries(lifted), w, h, settings.camera.fov_deg or DEFAULT_FOV_DEG,
                                settings.alignment, masks=scene.masks)
        camera, faces, verts, projected = placed.camera, placed.faces, placed.vertices, placed.projected
        shapes = ["external"] * len(lifted)
        notes = placed.info["mesh_notes"]
        align_info = placed.info
        given = settings.camera
        # what chose the view the meshes were placed under (the camera search may refine it after)
        align_info["fov_source"] = given.fov_source or (
            "user" if given.fov_deg is not None else f"default {DEFAULT_FOV_DEG:g}°")
        if settings.camera_search:
            found = search_camera(camera, verts, faces, scene.photo, scene.masks, scene.plate,
                                  max_evals=settings.camera_search_evals)
            camera = found.camera
            align_info["camera_search"] = {
                "loss": round(found.loss, 6), "initial_loss": round(found.initial_loss, 6),
                "evaluations": found.evaluations, "seconds": round(found.seconds, 3),
                "loss_curve": found.curve[:: max(1, len(found.curve) // 100)]}
    supports = {i: m.ground.support for i, m in enumerate(lifted) if m.ground is not None and m.ground.support}
    solved = solve_places(camera, verts, faces, [o.amodal for o in scene.objects], supports,
                          [o.mask.label for o in scene.objects],
                          [(k, i) for i, o in enumerate(scene.objects) for k in o.occluders], scene.masks)
    align_info["solve"] = solved.info | {"objects": [{"name": o.name, **s} for o, s in
                                                     zip(scene.objects, solved.info["objects"])]}
    verts = solved.vertices if shapes[0] == "external" else _deepened(scene, camera, solved.vertices, align_info)
    verts = _steadied(scene, camera, verts, faces, supports, align_info)
    verts = _separated(scene, camera, verts, faces, shapes, supports, align_info)
    _silhouette_report(scene, camera, verts, faces, align_info)
    centre = centring_offset(verts)
    scene.camera = camera.moved(centre)
    scene.align_info = align_info
    for o, v, seen, f, shape, note in zip(scene.objects, verts, projected, faces, shapes, notes):
        o.vertices, o.projected, o.faces, o.shape, o.notes = v + centre, seen + centre, f, shape, note
    rest = start_contacts([o.vertices for o in scene.objects], [o.faces for o in scene.objects], supports,
                          [o.name for o in scene.objects], held={i for i, o in enumerate(scene.objects) if _held(o)})
    for o, r in zip(scene.objects, rest):
        o.rest = r


def _silhouette_report(scene: Scene, camera, verts, faces, align_info: dict) -> None:
    """Each placed object as the shot shows it through the photo's camera (its mesh cut out by its mask, as its
    texture cuts it; hidden where a nearer one is opaque) against what the photo shows of it
    (``align.compare.visible_ious``), into ``align_info["silhouette_iou"]``, and a warning naming each object
    under ``align.compare.WARN_IOU``: the photo is the arbiter of the whole build, not of the pitch alone."""
    from .align.compare import WARN_IOU, mask_iou, silhouette, visible_ious

    ious = visible_ious(verts, faces, camera, scene.masks)
    align_info["silhouette_iou"] = {o.name: round(v, 4) for o, v in zip(scene.objects, ious)}
    # what the cut-outs hide: the bare mesh, whole, against the outline completed behind what hides it (a
    # mesh far wider than its outline collides where nothing is drawn; an outline's concavities lower it too)
    align_info["whole_outline_iou"] = {
        o.name: round(mask_iou(silhouette(v, f, camera), m if o.amodal is None else o.amodal), 4)
        for o, v, f, m in zip(scene.objects, verts, faces, scene.masks)}
    low = [(o.name, v) for o, v in zip(scene.objects, ious) if v < WARN_IOU]
    align_info.pop("silhouette_warnings", None)  # a settled pose is judged again: no warning of the one before
    if low:
        align_info["silhouette_warnings"] = [
            "the built scene does not match the photo's outline of " + ", ".join(
                f"{name} (silhouette IoU {v:.2f})" for name, v in low)
            + f" (under {WARN_IOU:g}); give its mask again, --size or --pitch"]


def _deepened(scene: Scene, camera, verts, align_info: dict) -> list:
    """The placed vertices with no lifted solid thinner than its outline allows (``metrics.geometry.thin_side``:
    a third of the outline's smaller side, a round thing round in depth, unless its label says flat): a thin
    one grows along its thin axis, away from the camera or up from its base. Run before the separation pass,
    which parts whatever the deeper object now presses."""
    from .align.place import deepen
    from .metrics.geometry import thin_side

    out, done = [], []
    for o, v in zip(scene.objects, verts):
        first = thin = thin_side(v, o.mask.label, camera.origin)
        for _ in range(3):  # the stretched solid's least width can lie along another direction: judge it again
            if thin is None:
                break
            v = deepen(v, thin, camera.origin)
            thin = thin_side(v, o.mask.label, camera.origin)
        if first is not None:
            done.append({"object": o.name, "from_m": round(first["thickness_m"], 4),
                         "to_m": round(first["need_m"], 4)})
        out.append(v)
    if done:
        align_info["deepened"] = done
    return out


def _steadied(scene: Scene, camera, verts, faces, supports, align_info: dict) -> list:
    """The placed vertices with every stacked object's centre of mass over the top of what holds it
    (``physics.support.steady_stacks``), so that nothing unpushed tips off its support; before the separation
    pass, which parts whatever a shift now presses."""
    from .physics.support import steady_stacks

    verts, done = steady_stacks(verts, faces, supports, camera.origin, [o.mask.label for o in scene.objects],
                                held={i for i, o in enumerate(scene.objects) if _held(o)})
    if done:
        names = [o.name for o in scene.objects]
        align_info["steadied"] = [d | {"object": names[d["object"]]} | ({"on": names[d["on"]]} if "on" in d else {})
                                  for d in done]
    return verts


def _separated(scene: Scene, camera, verts, faces, shapes, supports, align_info: dict) -> list:
    """The placed vertices with no pair deeper in each other than the contact margin (``align.separate``), so
    that ``simulate`` never refuses what ``build`` wrote; a pair no pass separates ends the build, named."""
    from .align.separate import Unseparable, separate_pairs
    from .errors import PhysOmniError
    from .physics.diagnose import PENETRATION_ERROR_FRACTION, PENETRATION_ERROR_M

    def refused(depth, a, b):  # as physics.diagnose.scene_findings judges a start overlap
        small = min(float(np.ptp(a.vertices, axis=0).min()), float(np.ptp(b.vertices, axis=0).min()))
        return depth > PENETRATION_ERROR_M and depth > PENETRATION_ERROR_FRACTION * small

    try:
        verts, done = separate_pairs(verts, faces, [s == "vessel" for s in shapes], supports, camera,
                                     scene.photo.shape[:2], [o.name for o in scene.objects], error=refused)
    except Unseparable as exc:
        raise PhysOmniError(f"{exc}, which no separation of the placed objects could undo, and simulate would "
                            f"refuse the scene; give their masks again (or --size, --pitch) and build again") from None
    if done:
        align_info["separated"] = done
    return verts


def _settle(scene: Scene, out: pathlib.Path, photo_path, user_sizes: dict, fields, files: set[str], echo) -> None:
    """The written shot settled with nothing pushed (``physics.settle``): where an object settles a little and
    its outline still matches the photo's, that pose is its rest pose and the shot is written again (and
    settled again, up to ``SETTLE_ROUNDS`` times: what came to rest in a hollow may still rock there); where
    one falls or rolls away, a warning names it and ``report.json`` keeps what it did (``alignment.settle``).

    Each round is judged from where the photo shows each object. A kept pose that starts inside another
    object as it will be written (one not kept goes back to the photo's pose) is dropped, until none does; one
    kept before that a later round finds gone too far goes back to the photo's pose, and what rests on or holds
    one going back, at a settled pose, goes back with it (:func:`_tie`). A round the simulator
    refuses puts the shot back to the last write it accepted, with a warning: the settle never makes a build
    fail that would pass without it, but for the shot as placed diverging (:func:`_refuse_placed`), which
    ``simulate`` would diverge on too. It settles the build's own layers (the artist's edits muted)."""
    from .errors import PhysOmniError
    from .physics.runner import Diverged
    from .physics.settle import SETTLE_ROUNDS, judge, settle_shot

    info: dict = {"rounds": []}
    scene.align_info["settle"] = info
    if fields:  # the shot's own motion under its fields is no placement's error: nothing to build a model for
        info["skipped"] = "force fields act on the shot"
        return
    names = [o.name for o in scene.objects]
    supports = {n: s["on"] for n, s in (scene.align_info.get("supports") or {}).items()}
    far: dict[str, str] = {}
    placed = [o.vertices.copy() for o in scene.objects]
    total: dict = {}
    verified: dict = {}  # the poses of the last write the simulator accepted (empty: the photo's)
    written = True  # the shot on disk is the one ``verified`` describes
    for _ in range(SETTLE_ROUNDS):
        try:
            settled = settle_shot(layers.open_shot(out, mute_sim=True, mute_edits=True), scene.settings.settle_s,
                                  echo)
        except PhysOmniError as exc:
            if _same(total, verified) and isinstance(exc, Diverged) and exc.finest:
                _refuse_placed(exc, supports, out, scene.settings.settle_s, echo)
            if _same(total, verified):  # the shot as placed, refused: the check after this says why
                info["skipped"] = str(exc)
            else:
                _settle_back(scene, verified, placed, out, photo_path, user_sizes, fields, files, info, exc, echo)
                total, written = dict(verified), True
            break
        if settled.colliders:
            info["colliders"] = settled.colliders
        if settled.skipped:
            info["skipped"] = settled.skipped
            break
        verified, written = dict(total), True
        # a pose kept before and still since is kept already: written again it costs a texturing and a settle
        again = {n for n, m in settled.motions.items() if m.still and n in total}
        settled.motions = {n: m.after(total.get(n), placed[names.index(n)]) for n, m in settled.motions.items()}
        keep, gone = judge(settled, names, placed, [o.faces for o in scene.objects], scene.camera, scene.masks)
        keep = {n: m for n, m in keep.items() if n not in again}
        # what rests on another and what holds it go back to the photo's pose together: a pot kept where it
        # settled under a plant put back where the photo shows it left the plant off its rim (511503/013: 1.0 →
        # 4.0 cm)
        tied = _tie(set(gone), (set(keep) | set(total)) - set(gone), supports)
        gone.update({n: TIED for n in tied})
        keep = {n: m for n, m in keep.items() if n not in gone}
        far.update(gone)
        undone = sorted(n for n in gone if n in total)  # kept before, gone too far since: back to the photo's
        for n in undone:
            total.pop(n)
        overlapping: list[str] = []
        while True:  # a pose dropped for starting inside another takes what it holds or rests on with it
            dropped = _settled_overlaps(scene, {**total, **keep}, placed, out)
            for n in dropped:
                far[n] = "settles to where it starts inside another object as written"
            tied = _tie(set(dropped), (set(keep) | set(total)) - set(dropped), supports)
            for n in tied:
                far[n] = TIED
            for n in (*dropped, *sorted(tied)):
                keep.pop(n, None)
                total.pop(n, None)
            overlapping += dropped + sorted(tied)
            if not tied:
                break
        info["rounds"].append({
            "simulated_s": round(settled.simulated_s, 3), "at_rest": settled.at_rest,
            "seconds": round(settled.seconds, 3),
            "motions": {n: {"moved_m": round(m.moved_m, 4), "turned_deg": round(m.turned_deg, 2)}
                        for n, m in settled.motions.items() if not m.still},
            **({"kept": sorted(keep)} if keep else {}), **({"undone": undone} if undone else {}),
            **({"overlapping": overlapping} if overlapping else {})})
        if not keep and not undone and not overlapping:
            break
        if keep:
            echo("build: settled " + ", ".join(f"{n} ({keep[n].moved_m * 1000:.0f} mm)" for n in sorted(keep))
                 + " where it came to rest; written again")
        total.update(keep)
        if _same(total, verified):  # only new poses dropped again: the shot on disk is the settled one
            break
        _rewrite_settled(scene, total, placed, out, photo_path, user_sizes, fields, files)
        written = False
    if not written:  # the last write was settled by no round: it must pass what simulate checks before it starts
        from .physics.prepare import refuse_unsimulatable

        try:
            refuse_unsimulatable(layers.open_shot(out, mute_sim=True, mute_edits=True), name=str(out / layers.SHOT))
        except PhysOmniError as exc:
            _settle_back(scene, verified, placed, out, photo_path, user_sizes, fields, files, info, exc, echo)
            total = dict(verified)
    info["kept"] = sorted(total)
    for n in total:
        far.pop(n, None)
    if far:
        info["not_kept"] = far
        for n, why in far.items():
            echo(f"warning: {n} does not stay where the photo shows it: it {why}; give its mask again, --size "
                 f"or --pitch, or hold it with --fixed")


def _refuse_placed(exc, supports: dict, out: pathlib.Path, seconds: float, echo) -> None:
    """End the build (exit 1, one line; the folder put back as it was) where the settle of the shot as placed
    diverged at its finest step (``exc``, a ``physics.runner.Diverged``) with nothing pushed, the guard's
    roll-backs and their re-armed separation included: ``simulate`` of the same shot would fail the same way,
    after a build that said it was written (a cup rocking on a book diverged in the settle; the build wrote it,
    and its check, which never simulates, passed it). What diverged is named with what it rests on or what
    rests on it (``supports``: upper's name → what it rests on).

    The settle steps the build's own layers; ``simulate`` composes the artist's ``edits.usda`` too. Where that
    layer says anything, the shot is settled again as ``simulate`` composes it, and refused only where that
    diverges too: an object the artist holds with ``physomni:fixed``, or gave another material or mass, may
    be what keeps it from diverging (then a warning says so and the settle is skipped)."""
    from .errors import PhysOmniError
    from .physics.runner import Diverged
    from .physics.settle import settle_shot

    if _edited(out):
        try:
            settle_shot(layers.open_shot(out, mute_sim=True), seconds, echo)
        except Diverged as again:
            if not again.finest:
                return
            exc = again
        except PhysOmniError:
            return
        else:
            echo(f"warning: the shot as placed diverges without {layers.EDITS} ({exc}); with it, it does not: "
                 "the shot is not settled")
            return
    pairs = []
    for n in exc.objects:
        on = [f"{n} on {supports[n]}"] if n in supports else []
        pairs += on + [f"{u} on {n}" for u, lower in sorted(supports.items()) if lower == n]
    which = f" ({'; '.join(dict.fromkeys(pairs))})" if pairs else ""
    raise PhysOmniError(f"the shot as placed diverges with nothing pushed{which}: {exc}; simulate would fail on "
                        "it too (give the objects' masks again, --size, or hold one with --fixed)") from None


def _edited(out: pathlib.Path) -> bool:
    """Whether the artist's ``edits.usda`` in ``out`` says anything about a prim (a rebuild keeps it)."""
    from pxr import Sdf

    edits = Sdf.Layer.FindOrOpen(str(out / layers.EDITS)) if (out / layers.EDITS).exists() else None
    return edits is not None and bool(edits.rootPrims)


def _same(a: dict, b: dict) -> bool:
    """The same settled poses (name → the same Motion)."""
    return a.keys() == b.keys() and all(a[n] is b[n] for n in a)


#: why an object's settled pose was not kept though it settled little: its neighbour's went back
TIED = "rests on, or holds, what was not kept"


def _tie(back: set[str], moved: set[str], supports: dict) -> set[str]:
    """The objects of ``moved`` (written at a settled pose) that rest on or hold one going back to the photo's
    pose (``back``), directly or through others so tied (``supports``: upper's name → the name of what it rests
    on). The tie runs only through objects that would move back: two fruits in a bowl that stays where the photo
    shows it are not tied to each other through it."""
    back, tied, grew = set(back), set(), True
    while grew:
        grew = False
        for upper, lower in supports.items():
            for a, b in ((upper, lower), (lower, upper)):
                if a in back and b in moved and b not in back:
                    back.add(b)
                    tied.add(b)
                    grew = True
    return tied


def _settle_back(scene: Scene, verified: dict, placed: list, out: pathlib.Path, photo_path, user_sizes: dict, fields,
                 files: set[str], info: dict, exc: Exception, echo) -> None:
    """The shot written again at the poses of the last write the simulator accepted (``verified``), after a
    settled write it refuses (``exc``): said, not skipped silently."""
    info["refused"] = str(exc)
    echo(f"warning: the settled shot would be refused ({exc}); the settle goes back to "
         + (f"its earlier poses of {', '.join(sorted(verified))}" if verified else "the photo's poses"))
    _rewrite_settled(scene, verified, placed, out, photo_path, user_sizes, fields, files)


def _settled_overlaps(scene: Scene, poses: dict, placed: list, out: pathlib.Path) -> list[str]:
    """Which of the settled ``poses`` (name → Motion) start inside another object as the shot would be written
    (the others at the photo's pose, ``placed``), by the check ``simulate`` refuses a shot on
    (``diagnose.penetration`` at 'error'): dropped one at a time, the deepest first, until none does."""
    import trimesh

    from .physics.diagnose import penetration
    from .physics.pieces import is_decomposed
    from .usd.author import OBJECTS

    if not poses:
        return []
    stage = layers.open_shot(out, mute_sim=True, mute_edits=True)
    names = [o.name for o in scene.objects]
    pieces = [is_decomposed(stage.GetPrimAtPath(f"{OBJECTS}/{n}")) for n in names]
    poses, dropped = dict(poses), []
    while poses:
        meshes = [trimesh.Trimesh(poses[n].apply(v) if n in poses else v, o.faces, process=False)
                  for n, v, o in zip(names, placed, scene.objects)]
        worst = None
        for i, a in enumerate(names):
            for j in range(i + 1, len(names)):
                b = names[j]
                if a not in poses and b not in poses:
                    continue  # the photo's poses: the build's own check judges those
                found = penetration(a, meshes[i], b, meshes[j], (pieces[i], pieces[j]))
                if found is None or found.severity != "error":
                    continue
                moved = [n for n in (a, b) if n in poses]
                culprit = found.name if found.name in moved else moved[0]
                if worst is None or found.badness > worst[0]:
                    worst = (found.badness, culprit)
        if worst is None:
            break
        dropped.append(worst[1])
        poses.pop(worst[1])
    return dropped


def _rewrite_settled(scene: Scene, keep: dict, placed: list, out: pathlib.Path, photo_path, user_sizes: dict,
                     fields, files: set[str]) -> None:
    """The shot written again with the settled poses ``keep`` (name → ``physics.settle.Motion``) and every other
    object where the photo shows it (``placed``): the objects' supports, silhouettes, textures and layers as the
    placement writes them."""
    names = [o.name for o in scene.objects]
    carried = [{k: o.report[k] for k in ("push", "fixed", "held") if k in o.report} for o in scene.objects]
    for o, v in zip(scene.objects, placed):
        o.vertices = keep[o.name].apply(v) if o.name in keep else v.copy()
    verts, faces = [o.vertices for o in scene.objects], [o.faces for o in scene.objects]
    supports = {i: o.lifted.ground.support for i, o in enumerate(scene.objects)
                if getattr(o.lifted, "ground", None) is not None and o.lifted.ground.support}
    for o, r in zip(scene.objects, start_contacts(verts, faces, supports, names,
                                                 held={i for i, o in enumerate(scene.objects) if _held(o)})):
        o.rest = r
    _silhouette_report(scene, scene.camera, verts, faces, scene.align_info)
    scene.scene_objects, scene.kept = [], {}
    _texture(scene, out, photo_path)
    for o, extra in zip(scene.objects, carried):
        o.report.update(extra)
    _write(scene, out, photo_path, user_sizes, fields, files)


def _occlusion_report(scene: Scene) -> list[dict]:
    """Who hides whom in the photo, and how much of it the placed meshes keep (``kept``: the fraction of the
    pixels where the photo shows the one in front whose ray meets its mesh before the other's)."""
    out = []
    for o in scene.objects:
        for k in o.occluders:
            kept = _kept(scene, o, k)
            out.append({"front": scene.objects[k].name, "behind": o.name,
                        "kept": None if kept is None else round(kept, 3)})
    return out


def _kept(scene: Scene, o, k: int) -> float | None:
    """:func:`occlusion_kept` of occluder ``k`` over object ``o`` (a ShotObject), measured once per build."""
    import trimesh

    key = (scene.objects.index(o), k)
    if key not in scene.kept:
        front = scene.objects[k]
        ys, xs = np.nonzero(front.mask.mask & o.amodal)
        scene.kept[key] = occlusion_kept(scene.camera, trimesh.Trimesh(front.vertices, front.faces, process=False),
                                         trimesh.Trimesh(o.vertices, o.faces, process=False), np.stack([xs, ys], 1))
    return scene.kept[key]


def _painted(scene: Scene, o) -> np.ndarray:
    """(H, W) bool at the photo's size: the part of ``o``'s completed outline that is painted in its texture,
    behind the occluders the placed meshes agree are in front of it (``texture.hidden.believed``)."""
    visible, amodal = _photo_size(scene, o)
    return painted_part(visible, amodal, [_photo_size(scene, scene.objects[k])[0] for k in o.occluders
                                          if not believed(_kept(scene, o, k))])


def _photo_size(scene: Scene, o) -> tuple[np.ndarray, np.ndarray]:
    """``o``'s mask and completed outline at the photo's size (``texture.objects.at_photo_size``)."""
    return at_photo_size(scene.work, o.mask.mask, o.amodal, o.full_mask)


def _texture(scene: Scene, out: pathlib.Path, photo_path=None) -> None:
    """Each object's texture from the photo, the plate, the contact sheet and the inputs, into the shot (the
    images encoded a few at a time, :class:`_PngWriter`)."""
    with _PngWriter() as writer:
        _texture_into(scene, out, photo_path, writer.write)


def _texture_into(scene: Scene, out: pathlib.Path, photo_path, write_png) -> None:
    import trimesh

    photo, camera = scene.photo, scene.camera
    if scene.work is not None:  # textures from the photo's own pixels, seen by the photo's camera
        photo, camera = scene.full_photo, scene.work.camera(scene.camera)
    make_dirs(out / TEXTURES)
    for so in scene.objects:
        o, v, f = so.mask, so.vertices, so.faces
        visible, amodal = _photo_size(scene, so)
        # where others hide it, the object is painted from its own visible surface (texture/hidden.py)
        painted = _painted(scene, so)
        tex = texture_object(photo, camera, visible, amodal, painted, so.projected, f,
                             open_back=so.shape == "extrude", work=scene.work)
        rgba, st, (x0, y0) = tex.rgba, tex.st, tex.origin
        tm = trimesh.Trimesh(v, f, process=False)
        origin = tm.center_mass if tm.is_volume else v.mean(0)
        rel = f"{TEXTURES}/{o.name}.png"
        write_png(out / rel, rgba)
        scene.scene_objects.append(SceneObject(o.name, o.label, o.index, v - origin, f,
                                               np.asarray(tm.vertex_normals), st, origin, f"./{rel}", so.shape,
                                               texture_origin=(x0, y0), st_per_corner=True))
        so.report = {
            "name": o.name, "label": o.label, "mask_index": o.index, "source": o.source,
            "shape": so.shape, "pixels": int(visible.sum()), "size_m": np.ptp(v, axis=0).round(4).tolist(),
            "position_m": origin.round(4).tolist(), "watertight": bool(tm.is_watertight), "notes": so.notes,
            "mask_quality": o.quality,
        }
        so.report["start"] = so.rest
        if so.occluders:
            so.report["occluded_by"] = [scene.objects[k].name for k in so.occluders]
            so.report["completed"] = {"how": so.completion, "pixels": int(painted.sum())}
    write_png(out / TEXTURES / "plate.png", scene.plate)
    write_png(out / TEXTURES / WIDE_PLATE, scene.wide_plate)
    # a check of the masks, not a picture: the working copy is enough for it
    write_png(out / MASKS_SHEET, contact_sheet(scene.photo, [o.mask for o in scene.objects],
                                                 completed=[o.amodal for o in scene.objects]))
    # the inputs, so that later stages (estimate's crops) work from the shot folder alone
    make_dirs(out / INPUTS / "masks")
    stream = None if photo_path is None else _plain_png(pathlib.Path(photo_path))
    if stream is not None:  # the photo's own pixels already compressed: kept, not encoded again
        write_bytes(out / INPUTS / "photo.png", stream)
    else:
        write_png(out / INPUTS / "photo.png", photo)
    for o in scene.objects:
        mask = _photo_size(scene, o)[0][..., None] * np.uint8(255)
        # a large photo's mask in one channel (a third of the encoding); readers take either
        write_png(out / INPUTS / "masks" / f"{o.name}.png", np.repeat(mask, 3, 2) if scene.work is None else mask)


def _held(o) -> bool:
    ground = getattr(o.lifted, "ground", None)
    return bool(ground is not None and (ground.info or {}).get("raised", {}).get("held"))


def _estimate(scene: Scene, push: dict, fixed_names: set[str]) -> None:
    """Each object's material from the estimator, its push and whether it is fixed."""
    scene.config = scene.backends["estimator"].estimate(scene.photo, scene.masks,
                                                        [o.mask.label for o in scene.objects], scene.settings.fps)
    for o in scene.objects:
        if o.name in push:
            o.report["push"] = {"velocity_m_s": list(push[o.name][0]), "at_s": push[o.name][1]}
        if o.name in fixed_names:
            o.report["fixed"] = True
    # what rests on something the masks do not show (a shelf, a wall: align.support.raise_unseen) is held where
    # the photo shows it; the artist frees it in edits.usda (physomni:fixed)
    held = {o.name for o in scene.objects if _held(o)}
    for o in scene.objects:
        if o.name in held - fixed_names:
            o.report["fixed"] = True
            o.report["held"] = "rests on what no mask shows (a shelf, a wall): held where the photo shows it"
    fixed_names = set(fixed_names) | held
    scene.physics_objects = []
    for o, cfg in zip(scene.objects, scene.config.objects):
        velocity, at = push.get(o.name, (None, 0.0))
        scene.physics_objects.append(PhysicsObject(
            o.name, cfg.material, cfg.params, scene.config.source, velocity=velocity if at == 0 else None,
            fixed=o.name in fixed_names,
            delayed_velocity=(velocity, at) if velocity is not None and at > 0 else None))


def _write(scene: Scene, out: pathlib.Path, photo_path, user_sizes: dict, fields, files: set[str]):
    """The shot's layers; returns the shot layer's path and the stale files of the previous build it removed."""
    # what the old build made that this one does not, read from the old report before anything is written
    stale = _stale_files(out, files)
    settings, camera = scene.settings, scene.camera
    h, w = (scene.photo if scene.full_photo is None else scene.full_photo).shape[:2]
    camera = camera if scene.work is None else scene.work.camera(camera)
    verts = [o.vertices for o in scene.objects]
    extent = max(np.abs(np.vstack(verts)[:, :2]).max() * 4.0, 20.0 * abs(float(camera.origin[2])))
    write_scene_layer(out / layers.SCENE, fps=settings.fps, image_size=(w, h), camera=camera,
                      plate=f"./{TEXTURES}/plate.png", objects=scene.scene_objects, ground_size=float(extent),
                      extra={"physomni:photo": str(pathlib.Path(photo_path).name),
                             **({"physomni:userSizes": {k: float(v) for k, v in user_sizes.items()}}
                                if user_sizes else {})},
                      photo=f"./{INPUTS}/photo.png", wide_plate=(f"./{TEXTURES}/{WIDE_PLATE}", scene.margins))
    write_physics_layer(out / layers.PHYSICS, out / layers.SCENE, fps=settings.fps, objects=scene.physics_objects,
                        ground=GROUND_MATERIAL, solver=DEFAULT_SOLVER, substeps=DEFAULT_SUBSTEPS,
                        iterations=DEFAULT_ITERATIONS, forces=fields)
    layers.reset_sim_layer(out, settings.fps)
    layers.ensure_edits_layer(out, settings.fps)
    shot = layers.write_shot_layer(out, settings.fps)
    for path in stale:
        remove_file(path)
    return shot, stale


def _png(path: pathlib.Path, image: np.ndarray) -> bytes:
    """An RGB(A) (or one-channel) image encoded as PNG, for ``path``."""
    if image.shape[2] != 1:
        image = cv2.cvtColor(image, cv2.COLOR_RGBA2BGRA if image.shape[2] == 4 else cv2.COLOR_RGB2BGR)
    ok, data = cv2.imencode(".png", image)
    if not ok:
        raise OSError(f"cannot encode {path.name}")
    return data.tobytes()


class _PngWriter:
    """PNG files written through a temporary file and a rename, encoded on a few threads (OpenCV encodes
    without the interpreter's lock; a 12 MP photo's plate, textures and inputs took seconds one after
    another). The files are written on leaving the block, by the calling thread, in the order asked (the
    command's journal of its writes, ``_files.all_or_nothing``, is its own); an error inside the block writes
    none of them."""

    THREADS = 4

    def __enter__(self):
        from concurrent.futures import ThreadPoolExecutor

        self._pool = ThreadPoolExecutor(max_workers=self.THREADS, thread_name_prefix="png")
        self._pending = []
        return self

    def write(self, path: pathlib.Path, image: np.ndarray) -> None:
        self._pending.append((path, self._pool.submit(_png, path, image)))

    def __exit__(self, kind, *_):
        self._pool.shutdown(wait=True, cancel_futures=kind is not None)
        if kind is None:
            for path, encoded in self._pending:
                write_bytes(path, encoded.result())
        return False


#: PNG chunks a copy of the photo keeps: the image itself; its text, EXIF and the like are left out of the shot.
_PNG_CRITICAL = (b"IHDR", b"PLTE", b"IDAT", b"IEND")


def _plain_png(path: pathlib.Path) -> bytes | None:
    """The photo file's own PNG stream with only its image chunks, where it is an 8-bit RGB PNG (what
    ``read_photo`` decodes it to, pixel for pixel, is then what encoding it again would store); else None."""
    import struct
    import zlib

    if path.suffix.lower() != ".png":
        return None
    data = path.read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n" or data[12:16] != b"IHDR" or data[24:26] != bytes([8, 2]):
        return None
    out, at = [data[:8]], 8
    while at + 12 <= len(data):
        (n,) = struct.unpack(">I", data[at:at + 4])
        kind, end = data[at + 4:at + 8], at + 12 + n
        if end > len(data) or zlib.crc32(data[at + 4:end - 4]) != struct.unpack(">I", data[end - 4:end])[0]:
            return None  # damaged: encoded again from the pixels that were read
        if kind in _PNG_CRITICAL:
            out.append(data[at:end])
        at = end
        if kind == b"IEND":
            return b"".join(out)
    return None
