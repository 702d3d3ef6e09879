"""Running the chosen backends inside ``build``: objects from prompts, the plate, lifting."""

from __future__ import annotations

import json
import inspect
import math
import pathlib

import cv2
import numpy as np

from .._files import write_bytes
from ..errors import InputError
from ..swappable import registry
from ..swappable.protocols import Prompt

#: The options ``build``/``run`` take, one per kind used during build, and the kind each selects.
BUILD_KINDS = ("segmenter", "inpainter", "outpainter", "lifter", "depth", "estimator")


def resolve(choices: dict | None, meshes_dir=None) -> dict:
    """Kind → loaded backend for every build step (defaults where ``choices`` names none; depth may be None).

    Raises :class:`InputError` (exit 2) for an unknown name, a backend that is
    not ready or a lifter given with ``--meshes``, before anything is computed
    or written.
    """
    choices = {k: v for k, v in (choices or {}).items() if v}
    if meshes_dir is not None and choices.get("lifter"):
        raise InputError(f"--lifter {choices['lifter']} and --meshes both give the meshes; pass one of them")
    out = {}
    for kind in BUILD_KINDS:
        name = choices.get(kind) or registry.DEFAULTS[kind]
        out[kind] = registry.load(kind, name) if name else None
    return out


def report(backends: dict) -> dict:
    """Step → description, for ``report.json``."""
    return {kind: registry.describe(b) for kind, b in backends.items() if b is not None}


def collect_objects(photo: np.ndarray, mask_specs, box_specs, segmenter, progress=None):
    """Like ``perceive.masks.collect_masks`` (``progress`` as it takes it), but boxes are cut by ``segmenter``."""
    from ..perceive.masks import ObjectMask, box_clicks, checked_mask, collect_masks, parse_box, read_mask

    if type(segmenter).name == "grabcut" or not box_specs:
        return collect_masks(photo, mask_specs, box_specs, progress)
    specs = list(mask_specs or ())
    objects = [read_mask(s, photo.shape[:2], i) for i, s in enumerate(specs)]
    h, w = photo.shape[:2]
    prompts, labels = [], []
    for spec in box_specs:
        (x0, y0, x1, y1), label = parse_box(spec)
        if not (0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h):
            raise InputError(f"--box {spec!r} is not inside the {w}×{h} photo "
                             f"(need 0 ≤ X0 < X1 ≤ {w}, 0 ≤ Y0 < Y1 ≤ {h})")
        clicks = [(float(x), float(y), on) for x, y, on in box_clicks(spec)]
        outside = [(x, y) for x, y, _ in clicks if not (0 <= x < w and 0 <= y < h)]
        if outside:
            raise InputError(f"--box {spec!r}: the click at {outside[0][0]:g},{outside[0][1]:g} is not inside the "
                             f"{w}×{h} photo")
        prompts.append(Prompt(box=(x0, y0, x1, y1), points=clicks))
        labels.append(label)
    masks = segmenter.segment(photo, prompts)
    for j, (spec, p, label, mask) in enumerate(zip(box_specs, prompts, labels, masks)):
        mask = checked_mask(np.asarray(mask, bool), f"--box {spec!r} ({type(segmenter).name})")
        index = len(specs) + j
        objects.append(ObjectMask(label or f"object{index}", index, mask, "box:" + ",".join(map(str, p.box))))
    return objects


def collect_working(work, small: np.ndarray, mask_specs, box_specs, segmenter, progress=None):
    """The objects of the masks and boxes given in photo pixels, cut and measured on the working copy
    ``small`` of a photo that ``work`` (``perceive.working.Working``) reduced, numbered as
    :func:`collect_objects` numbers them; and each file mask at the photo's
    size (None for a box's), whose edge the texture keeps."""
    from ..perceive.masks import box_clicks, check_box, checked_mask, mask_quality, parse_box, read_mask

    specs, boxes = list(mask_specs or ()), list(box_specs or ())
    if not specs and not boxes:
        return collect_objects(small, specs, boxes, segmenter, progress), []
    objects, full = [], []
    for i, spec in enumerate(specs):
        o = read_mask(spec, work.full, i)
        full.append(o.mask)
        o.mask = checked_mask(work.down_mask(o.mask), f"mask {o.source[len('file:'):]} at the working size "
                                                      f"{work.work[1]}×{work.work[0]}")
        o.quality = dict(mask_quality(small, o.mask), method=o.quality["method"])
        objects.append(o)
    for spec in boxes:
        check_box(spec, work.full)
    cut = collect_objects(small, [], [work.box_spec(s) for s in boxes], segmenter, progress) if boxes else []
    for j, (spec, o) in enumerate(zip(boxes, cut)):
        o.index = len(specs) + j
        o.label = parse_box(spec)[1] or f"object{o.index}"
        (x0, y0, x1, y1), _ = parse_box(spec)  # the report names the box as it was given
        o.source = f"box:{x0},{y0},{x1},{y1}" + "".join(f":{'+' if on else '-'}{x},{y}"
                                                       for x, y, on in box_clicks(spec))
        full.append(None)
    return objects + cut, full


def hole(masks, shape: tuple[int, int], dilation: float) -> np.ndarray:
    """Union of the masks widened by ``dilation`` × the image diagonal, (H, W) bool."""
    h, w = shape
    out = np.zeros((h, w), np.uint8)
    for m in masks:
        out |= m.astype(np.uint8)
    r = int(round(dilation * math.hypot(h, w)))
    if r > 0:
        out = cv2.dilate(out, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
    return out > 0


#: Width of each outpainted margin of the wide plate, as a fraction of the plate's side it extends.
OUTPAINT_MARGIN = 0.5


def make_wide_plate(plate: np.ndarray, outpainter) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """The plate extended on every side by :data:`OUTPAINT_MARGIN` of its size for camera moves, and the
    margins (top, bottom, left, right) in pixels; the plate's own pixels are kept as they are."""
    h, w = plate.shape[:2]
    my, mx = round(OUTPAINT_MARGIN * h), round(OUTPAINT_MARGIN * w)
    margins = (my, my, mx, mx)
    wide = np.asarray(outpainter.outpaint(plate, margins))
    if wide.shape != (h + 2 * my, w + 2 * mx, 3):
        raise InputError(f"outpainter {type(outpainter).name} returned an image of shape {wide.shape}, "
                         f"expected {(h + 2 * my, w + 2 * mx, 3)}")
    wide = np.array(wide, np.uint8)
    wide[my:my + h, mx:mx + w] = plate
    return wide, margins


def make_plate(photo: np.ndarray, masks, dilation: float, inpainter, sources=None, camera=None,
               weight=None) -> np.ndarray:
    """The background plate: the built-in's own, or the photo with the inpainter's fill in the hole only.
    ``sources``: where the built-in's exemplar fill copied each pixel from (``texture.fill.background_plate``),
    if it is the built-in; a plugin's fill says nothing of the kind. ``camera``: the ground's camera, when the
    lifter measured one, for a fill that takes it (the built-in fills the floor top-down). ``weight``: where the
    built-in writes each pixel's share of its fill, if it is the built-in."""
    if hasattr(inpainter, "plate"):
        takes = inspect.signature(inpainter.plate).parameters
        extra = ({"sources": sources} if sources is not None and "sources" in takes else {}) | (
            {"camera": camera} if camera is not None and "camera" in takes else {}) | (
            {"weight": weight} if weight is not None and "weight" in takes else {})
        return inpainter.plate(photo, masks, dilation, **extra)
    where = hole(masks, photo.shape[:2], dilation)
    filled = np.asarray(inpainter.inpaint(photo, where))
    if filled.shape != photo.shape:
        raise InputError(f"inpainter {type(inpainter).name} returned an image of shape {filled.shape}, "
                         f"not the photo's {photo.shape}")
    return np.where(where[..., None], np.clip(filled, 0, 255).astype(np.uint8), photo)


def lift(lifter, photo: np.ndarray, objects, settings, sizes: dict, masks=None) -> list:
    """Every object's mesh and pose from ``lifter`` (any :class:`~.protocols.Lifter`), checked.

    ``masks``: the outlines to lift, (H, W) bool each (default the objects' own). The keywords
    ``settings``, ``names``, ``sizes`` and ``visible`` (the objects' own masks, what the photo shows of each
    when ``masks`` are completed behind occluders) go to a lifter whose ``lift`` takes them."""
    import inspect

    params = inspect.signature(lifter.lift).parameters
    context = {k: v for k, v in (("settings", settings), ("names", [o.name for o in objects]), ("sizes", sizes),
                                 ("visible", [o.mask for o in objects])) if k in params}
    masks = [o.mask for o in objects] if masks is None else masks
    lifted = list(lifter.lift(photo, masks, [o.label for o in objects], **context))
    name = type(lifter).name
    if len(lifted) != len(objects):
        raise InputError(f"lifter {name} returned {len(lifted)} meshes for {len(objects)} objects")
    for o, m in zip(objects, lifted):
        if len(m.vertices) < 4 or len(m.faces) < 4:
            raise InputError(f"lifter {name} returned an empty mesh for {o.label!r}")
    if len({m.ground is None for m in lifted}) > 1:
        raise InputError(f"lifter {name} stood some meshes on a measured ground and posed others in the camera")
    return lifted


def record_lifted(lifted, objects, folder: pathlib.Path) -> pathlib.Path:
    """Write what a model lifter returned as ``build --meshes`` reads it: one PLY per object and poses.json."""
    import trimesh

    folder.mkdir(parents=True, exist_ok=True)
    poses = {}
    for o, m in zip(objects, lifted):
        name = f"{o.name}.ply"
        data = trimesh.Trimesh(np.asarray(m.vertices, float), np.asarray(m.faces, np.int64), process=False)
        write_bytes(folder / name, data.export(file_type="ply"))
        poses[o.label] = {"mesh": name, "rotation_wxyz": [float(x) for x in m.rotation_wxyz],
                          "translation": [float(x) for x in m.translation], "scale": float(m.scale)}
    write_bytes(folder / "poses.json", (json.dumps(poses, indent=2) + "\n").encode())
    return folder
