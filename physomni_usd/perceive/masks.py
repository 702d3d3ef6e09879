"""Reading the photo and the object masks, or making masks from boxes with GrabCut."""

from __future__ import annotations

import pathlib
import re
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError

#: Fewest pixels a mask may have and still describe an object.
MIN_MASK_PIXELS = 16
GRABCUT_ITERATIONS = 5


@dataclass
class ObjectMask:
    """One object of the photo: its label, its position among the inputs, its pixels."""

    label: str
    index: int
    mask: np.ndarray  # (H, W) bool
    source: str  # 'file:<path>' or 'box:x0,y0,x1,y1'

    @property
    def name(self) -> str:
        """USD prim name: the label as an identifier, then the index (``cup_0``)."""
        return f"{identifier(self.label)}_{self.index}"


def identifier(label: str) -> str:
    """A valid USD identifier made from ``label`` (letters, digits, underscores)."""
    s = re.sub(r"[^A-Za-z0-9_]", "_", label.strip()) or "object"
    if s[0].isdigit():
        s = "_" + s
    return s


def decode_image(path: pathlib.Path) -> np.ndarray | None:
    """The file decoded by OpenCV as stored (any depth and channels), or None; OpenCV's own warnings about
    a damaged file (a truncated PNG) are kept off the terminal, the caller says it in one line."""
    data = np.fromfile(str(path), dtype=np.uint8)
    if not data.size:
        return None
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    try:
        return cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    finally:
        cv2.utils.logging.setLogLevel(level)


def read_photo(path: str | pathlib.Path) -> np.ndarray:
    """The photo as (H, W, 3) uint8 RGB; alpha is dropped, grey becomes RGB."""
    p = pathlib.Path(path)
    if not p.is_file():
        raise InputError(f"photo not found: {p}")
    img = decode_image(p)
    if img is None:
        raise InputError(f"cannot read {p} as an image (PNG, JPEG, TIFF, …)")
    if img.dtype != np.uint8:
        img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    if img.ndim == 2:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
    elif img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGB)
    else:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    if min(img.shape[:2]) < 16:
        raise InputError(f"{p} is {img.shape[1]}×{img.shape[0]} pixels; the photo must be at least 16 on each side")
    return np.ascontiguousarray(img)


def split_spec(spec: str) -> tuple[str, str | None]:
    """``'path/cup.png:cup'`` → ``('path/cup.png', 'cup')``; a label never holds a path separator."""
    head, sep, tail = spec.rpartition(":")
    if sep and head and tail and not re.search(r"[\\/]", tail):
        return head, tail
    return spec, None


def read_mask(spec: str, shape: tuple[int, int], index: int) -> ObjectMask:
    """Read ``PNG[:LABEL]``: non-zero pixels (or non-zero alpha, where alpha is used) belong to the object."""
    path_s, label = split_spec(spec)
    p = pathlib.Path(path_s)
    if not p.is_file():
        raise InputError(f"mask not found: {p}")
    img = decode_image(p)
    if img is None:
        raise InputError(f"cannot read mask {p} as an image")
    if img.shape[:2] != tuple(shape):
        raise InputError(f"mask {p.name} is {img.shape[1]}×{img.shape[0]} but the photo is {shape[1]}×{shape[0]}; "
                         "masks must have the photo's resolution")
    if img.ndim == 3 and img.shape[2] == 4 and img[..., 3].min() < img[..., 3].max():
        mask = img[..., 3] > 0  # a cut-out: the alpha channel is the mask, not the luminance
    elif img.ndim == 3:
        mask = (img[..., :3] > 0).any(axis=2)
    else:
        mask = img > 0
    return ObjectMask(label or p.stem, index, _checked(mask, f"mask {p.name}"), f"file:{p}")


def parse_box(spec: str) -> tuple[tuple[int, int, int, int], str | None]:
    """``'X0,Y0,X1,Y1[:LABEL]'`` → ((x0, y0, x1, y1), label)."""
    coords, _, label = spec.partition(":")
    try:
        x0, y0, x1, y1 = (int(round(float(c))) for c in coords.split(","))
    except ValueError:
        raise InputError(f"--box {spec!r}: expected X0,Y0,X1,Y1[:LABEL] with four numbers") from None
    return (x0, y0, x1, y1), (label or None)


def mask_from_box(photo: np.ndarray, spec: str, index: int) -> ObjectMask:
    """Segment the object inside a box with OpenCV GrabCut."""
    (x0, y0, x1, y1), label = parse_box(spec)
    h, w = photo.shape[:2]
    if x1 <= x0 or y1 <= y0:
        raise InputError(f"--box {spec!r}: X1 must be greater than X0 and Y1 greater than Y0 (the corners are "
                         "top-left, then bottom-right)")
    if not (0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h):
        raise InputError(f"--box {spec!r} is not inside the {w}×{h} photo (need 0 ≤ X0 < X1 ≤ {w}, 0 ≤ Y0 < Y1 ≤ {h})")
    if x1 - x0 < 4 or y1 - y0 < 4:
        raise InputError(f"--box {spec!r} is smaller than 4×4 pixels")
    mask = np.full((h, w), cv2.GC_BGD, np.uint8)
    bgd = np.zeros((1, 65), np.float64)
    fgd = np.zeros((1, 65), np.float64)
    bgr = cv2.cvtColor(photo, cv2.COLOR_RGB2BGR)
    if (x1 - x0) * (y1 - y0) >= 0.98 * w * h:
        # GrabCut needs some background to model; a box over the whole photo keeps the box.
        result = np.zeros((h, w), bool)
        result[y0:y1, x0:x1] = True
    else:
        cv2.grabCut(bgr, mask, (x0, y0, x1 - x0, y1 - y0), bgd, fgd, GRABCUT_ITERATIONS, cv2.GC_INIT_WITH_RECT)
        result = (mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD)
        result = largest_component(result)
    return ObjectMask(label or f"object{index}", index, _checked(result, f"--box {spec!r}"), f"box:{x0},{y0},{x1},{y1}")


def largest_component(mask: np.ndarray) -> np.ndarray:
    """The largest 8-connected component of a boolean mask (the mask itself if it is empty)."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 2:
        return mask
    keep = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return labels == keep


def _checked(mask: np.ndarray, what: str) -> np.ndarray:
    count = int(mask.sum())
    if count == 0:
        raise InputError(f"{what} is empty: no pixel belongs to the object")
    if count < MIN_MASK_PIXELS:
        raise InputError(f"{what} has only {count} pixels; an object needs at least {MIN_MASK_PIXELS}")
    if count == mask.size:
        raise InputError(f"{what} covers the whole photo; nothing would be left for the ground and background")
    return mask


def collect_masks(photo: np.ndarray, mask_specs, box_specs) -> list[ObjectMask]:
    """All objects, numbered in the order given: masks first, then boxes."""
    specs = list(mask_specs or ())
    boxes = list(box_specs or ())
    if not specs and not boxes:
        raise InputError("no objects given: pass --mask PNG[:LABEL] or --box X0,Y0,X1,Y1[:LABEL] at least once")
    shape = photo.shape[:2]
    objects = [read_mask(s, shape, i) for i, s in enumerate(specs)]
    objects += [mask_from_box(photo, s, len(specs) + j) for j, s in enumerate(boxes)]
    return objects
