"""Reading the photo and the object masks, or making masks from boxes with GrabCut; how far each mask
can be trusted (:func:`mask_quality`), and a contact sheet of them over the photo (:func:`contact_sheet`)."""

from __future__ import annotations

import pathlib
import re
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError
from .amodal import hull_points

#: Fewest pixels a mask may have and still describe an object.
MIN_MASK_PIXELS = 16
GRABCUT_ITERATIONS = 5
#: GrabCut's graph spans every pixel of the photo, and its cost grows with them (about 23 CPU seconds for one
#: cut of 5 iterations on a megapixel): a box on a photo of more than GRABCUT_PIXELS pixels is cut on a copy
#: reduced to GRABCUT_WORK_PIXELS, and only the band along that mask's edge is cut again at the photo's size
#: (:func:`refine_edge`). Where GrabCut finds the object at either size, the two masks agree to 0.96–0.99 IoU
#: (boxes around the motorcycle's and the parts photo's objects at 1 MP; tests/test_grabcut_coarse.py), at a
#: fifth of the cost. Every bundled example's photo (0.37 MP at most) is cut as it is.
GRABCUT_PIXELS = 400_000
GRABCUT_WORK_PIXELS = 250_000
#: The band cut again at the photo's size reaches this many pixels of the reduced copy either side of its
#: mask's edge (the copy's edge is within a pixel or two of the object's), in REFINE_ITERATIONS iterations.
REFINE_BAND = 3
REFINE_ITERATIONS = 2
#: A mask looks like background when more than this fraction of its pixels have the colours of the
#: surroundings of its box (a colour common there: within the distance below of at least
#: BACKGROUND_SHARE of the pixels sampled around it) ...
BACKGROUND_LIKE = 0.25
BACKGROUND_SHARE = 0.1
#: ... or when less than this fraction of its outline follows an edge of the photo.
MIN_EDGE_AGREEMENT = 0.15
#: Colour distance (CIELab units) within which a pixel counts as having a background colour.
BACKGROUND_COLOUR_DISTANCE = 10.0
#: Words of labels of things with limbs or legs (people, animals, furniture on legs): their box holds ground
#: between the limbs, often in the thing's own shadow, which GrabCut's colour models keep as object.
LIMBED = frozenset({
    "person", "people", "man", "men", "woman", "women", "child", "children", "kid", "boy", "girl", "player",
    "footballer", "runner", "athlete", "human", "dancer", "skier", "skater", "cat", "dog", "horse", "cow",
    "sheep", "goat", "pig", "deer", "giraffe", "zebra", "elephant", "bear", "lion", "tiger", "animal", "bird",
    "chair", "stool", "table", "bicycle", "bike", "tripod", "robot"})
#: Chromaticity distance (r, g shares of r + g + b) within which a pixel has a colour of the ground around the
#: box whatever its light: a shadow darkens the ground but keeps its chromaticity.
GROUND_CHROMA_DISTANCE = 0.02
#: A pixel darker than this (r + g + b, of 765) has no chromaticity to trust.
DARKEST_CHROMA = 45.0
#: A round outline (circularity of its convex hull at least this) whose mask misses more than this share of
#: its hull has holes or bites: a ball's dark panels left out.
ROUND_CIRCULARITY = 0.85
ROUND_MISSING = 0.06
#: Pixels within this many of another object's mask are that object's side of a shared outline (masks of
#: neighbours drawn or rendered apart leave a pixel or two between them): neither background around this
#: object, nor its own outline, nor a part of it left out (:func:`qualify_among`).
OCCLUDER_REACH = 2


@dataclass
class ObjectMask:
    """One object of the photo: its label, its position among the inputs, its pixels."""

    label: str
    index: int
    mask: np.ndarray  # (H, W) bool
    source: str  # 'file:<path>' or 'box:x0,y0,x1,y1'
    quality: dict | None = None  # from mask_quality, plus 'method' for box masks

    @property
    def name(self) -> str:
        """USD prim name: the label as an identifier, then the index (``cup_0``)."""
        return f"{identifier(self.label)}_{self.index}"


#: The longest label, in characters: a label names its object's prim and the object's texture and mask files,
#: whose names (with our temporary files' ``.NAME.physomni-XXXXXXXX.png``) a file system holds to 255 bytes.
MAX_LABEL = 100


def checked_label(label: str, option: str, spec: str) -> str:
    """``label`` if it is short enough to name files, else :class:`InputError` naming the option."""
    if len(label) > MAX_LABEL:
        shown = spec if len(spec) <= 60 else spec[:40] + "…"
        raise InputError(f"{option} {shown!r}: the label is {len(label):,} characters long; at most {MAX_LABEL}")
    return label


def check_labels(masks=(), boxes=()) -> None:
    """Refuse an over-long label of any ``--mask`` or ``--box`` before any work (GrabCut of the boxes before
    it would take seconds each)."""
    for spec in masks:
        path_s, label = split_spec(spec)
        checked_label(label or pathlib.Path(path_s).stem, "--mask", spec)
    for spec in boxes:
        label = parse_box(spec)[1]
        if label is not None:
            checked_label(label, "--box", spec)


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


def photo_size(path: pathlib.Path) -> tuple[int, int] | None:
    """(width, height) from the image file's header alone (nothing is decoded), or None where Pillow
    cannot read the header (OpenCV may still decode the file)."""
    from PIL import Image

    bomb, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, None  # we judge the size ourselves, from the header
    try:
        with Image.open(path) as im:  # reads the header only
            return int(im.size[0]), int(im.size[1])
    except Exception:  # not an image Pillow knows, or a damaged header: decoding will say so
        return None
    finally:
        Image.MAX_IMAGE_PIXELS = bomb


def check_photo_size(path: str | pathlib.Path, max_pixels: int) -> None:
    """Refuse (one line, exit 2) a photo larger than ``max_pixels`` before anything decodes it: decoding
    a 30000 × 30000 PNG of a few MB takes gigabytes."""
    p = pathlib.Path(path)
    size = photo_size(p) if p.is_file() else None
    if size is not None and size[0] * size[1] > max_pixels:
        w, h = size
        raise InputError(f"{p} is {w}×{h} pixels ({w * h / 1e6:.1f} MP); at most {max_pixels / 1e6:g} MP "
                         "(--max-pixels): scale the photo down, or raise --max-pixels where the memory is there")


def read_photo(path: str | pathlib.Path, max_pixels: int | None = None) -> np.ndarray:
    """The photo as (H, W, 3) uint8 RGB; alpha is dropped, grey becomes RGB. ``max_pixels``: refuse a
    larger photo from its header, before decoding [default: ``BuildSettings().max_pixels``]."""
    p = pathlib.Path(path)
    if not p.is_file():
        raise InputError(f"photo not found: {p}")
    if max_pixels is None:
        from ..settings import BuildSettings

        max_pixels = BuildSettings().max_pixels
    check_photo_size(p, max_pixels)
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
    return ObjectMask(checked_label(label or p.stem, "--mask", spec), index, checked_mask(mask, f"mask {p.name}"), f"file:{p}",
                      {"method": "file"})


#: A click, inside a box's spec: ``+X,Y`` on the object, ``-X,Y`` off it (pixels).
CLICK = re.compile(r"^([+-])(\d+(?:\.\d*)?),(\d+(?:\.\d*)?)$")
#: Radius of the pixels a click decides, as a share of its box's shorter side (at least 2 pixels).
CLICK_RADIUS = 0.04


def parse_box(spec: str) -> tuple[tuple[int, int, int, int], str | None]:
    """``'X0,Y0,X1,Y1[:LABEL][:+X,Y][:-X,Y]...'`` → ((x0, y0, x1, y1), label); clicks: :func:`box_clicks`."""
    coords, _, rest = spec.partition(":")
    try:
        x0, y0, x1, y1 = (int(round(float(c))) for c in coords.split(","))
    except ValueError:
        raise InputError(f"--box {spec!r}: expected X0,Y0,X1,Y1[:LABEL] with four numbers") from None
    words = [w for w in rest.split(":") if w and not CLICK.match(w.strip())] if rest else []
    return (x0, y0, x1, y1), (":".join(words) or None)


def box_clicks(spec: str) -> list[tuple[int, int, bool]]:
    """The clicks of a box's spec, in order: ``'10,10,90,90:cup:+50,40:-20,80'`` → [(50, 40, True),
    (20, 80, False)] (pixels; True: the pixel belongs to the object)."""
    _, _, rest = spec.partition(":")
    out = []
    for word in rest.split(":") if rest else ():
        m = CLICK.match(word.strip())
        if m:
            out.append((int(round(float(m.group(2)))), int(round(float(m.group(3)))), m.group(1) == "+"))
    return out


def box_spec(box, label: str | None = None, clicks=()) -> str:
    """The ``--box`` spec of a box, its label and its clicks (the inverse of :func:`parse_box` and
    :func:`box_clicks`)."""
    words = [",".join(str(int(c)) for c in box)] + ([label] if label else [])
    words += [f"{'+' if on else '-'}{int(x)},{int(y)}" for x, y, on in clicks]
    return ":".join(words)


def mask_from_box(photo: np.ndarray, spec: str, index: int) -> ObjectMask:
    """Segment the object inside a box with OpenCV GrabCut, then correct it by the spec's clicks. A photo of
    more than :data:`GRABCUT_PIXELS` pixels is cut coarse to fine: on a reduced copy, then along the edge at its
    own size (:func:`refine_edge`)."""
    (x0, y0, x1, y1), label = parse_box(spec)
    if label is not None:
        checked_label(label, "--box", spec)
    h, w = photo.shape[:2]
    check_box(spec, (h, w))
    clicks = box_clicks(spec)
    box = (x0, y0, x1, y1)
    if h * w > GRABCUT_PIXELS and (clicks or not _covers_whole(box, w, h)):
        result, quality = _coarse_to_fine(photo, spec, box, clicks, index)
    else:
        result, quality = _full_size(photo, box, label, clicks)
    source = f"box:{x0},{y0},{x1},{y1}" + "".join(f":{'+' if on else '-'}{x},{y}" for x, y, on in clicks)
    obj = ObjectMask(label or f"object{index}", index, checked_mask(result, f"--box {spec!r}"), source)
    obj.quality = quality
    return obj


def _covers_whole(box, w: int, h: int) -> bool:
    """Whether ``box`` (x0, y0, x1, y1) covers (nearly) all of a ``w`` × ``h`` photo, leaving GrabCut no
    background to model."""
    x0, y0, x1, y1 = box
    return (x1 - x0) * (y1 - y0) >= 0.98 * w * h


def _coarse_to_fine(photo: np.ndarray, spec: str, box, clicks, index: int) -> tuple[np.ndarray, dict]:
    """:func:`mask_from_box` of ``spec`` on a copy of ``photo`` reduced to :data:`GRABCUT_WORK_PIXELS` (area
    averaging; the box widened to whole reduced pixels, each click on the reduced pixel holding it), its edge cut
    again at the photo's size; the mask (H, W) bool and its quality, measured at the photo's size (what the
    reduced cut alone knows, ``method`` and ``ground_like``, is kept from it)."""
    h, w = photo.shape[:2]
    s = float(np.sqrt(GRABCUT_WORK_PIXELS / (h * w)))
    sw, sh = max(16, int(w * s)), max(16, int(h * s))
    fx, fy = w / sw, h / sh
    x0, y0, x1, y1 = box
    small_box = (int(np.floor(x0 / fx)), int(np.floor(y0 / fy)), min(sw, int(np.ceil(x1 / fx))),
                 min(sh, int(np.ceil(y1 / fy))))
    small_clicks = [(min(sw - 1, int(x / fx)), min(sh - 1, int(y / fy)), on) for x, y, on in clicks]
    label = parse_box(spec)[1]
    if _covers_whole(box, w, h) != _covers_whole(small_box, sw, sh):
        # widened to whole reduced pixels, a box just short of the whole photo covers all of the copy: the
        # copy would keep the box where the photo is cut
        return _full_size(photo, box, label, clicks)
    try:
        small = mask_from_box(cv2.resize(photo, (sw, sh), interpolation=cv2.INTER_AREA),
                              box_spec(small_box, label, small_clicks), index)
    except InputError:  # nothing left at the reduced size (a sliver of a box): cut it at the photo's size
        return _full_size(photo, box, label, clicks)
    # back at the photo's size, the staircase smoothed (cv2.resize maps pixel centres exactly)
    up = cv2.resize(small.mask.astype(np.uint8) * 255, (w, h), interpolation=cv2.INTER_LINEAR) >= 128
    mask = refine_edge(photo, up, box, clicks, max(fx, fy))
    quality = dict(small.quality or {})
    if mask.any():
        coarse_warning = quality.get("warning")
        quality.update(mask_quality(photo, mask, box))
        if quality["warning"] is None and (quality.get("ground_like") or 0.0) > BACKGROUND_LIKE:
            quality["warning"] = coarse_warning
    return mask, quality


def _full_size(photo: np.ndarray, box, label, clicks) -> tuple[np.ndarray, dict]:
    """``box`` cut on ``photo`` as it is (a box over the whole photo kept as it is), then its ``clicks``: the
    mask and its quality."""
    h, w = photo.shape[:2]
    x0, y0, x1, y1 = box
    if _covers_whole(box, w, h):
        # GrabCut needs some background to model; a box over the whole photo keeps the box.
        result = np.zeros((h, w), bool)
        result[y0:y1, x0:x1] = True
        quality = {"method": "box"}
    else:
        result, quality = segment_box(photo, box, label)
    if clicks:
        result = refine_with_clicks(photo, box, result, clicks)
        quality = dict(mask_quality(photo, result, box), method=quality["method"] + "+clicks") \
            if result.any() else {"method": quality["method"] + "+clicks"}
    return result, quality


def refine_edge(photo: np.ndarray, mask: np.ndarray, box, clicks=(), scale: float = 1.0) -> np.ndarray:
    """``mask`` (H, W) bool, cut on a copy of ``photo`` reduced ``scale`` × and brought back to its size, cut
    again along its edge at the photo's size: GrabCut decides only a band :data:`REFINE_BAND` reduced pixels
    either side of the edge (inside it the object, beyond it and outside ``box`` the background, and each of
    ``clicks`` a disc as :func:`refine_with_clicks` draws it), on the part of the photo around that band. The
    parts that hold the band's inner side are kept (those holding a click on the object, where there are
    any). Its cost follows the edge's length, not the photo's area."""
    x0, y0, x1, y1 = box
    h, w = mask.shape
    if not mask.any():
        return mask
    r = max(2, int(np.ceil(REFINE_BAND * scale)))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    m8 = mask.astype(np.uint8)
    inner = cv2.erode(m8, kernel) > 0
    outer = cv2.dilate(m8, kernel) > 0
    labels = np.where(inner, cv2.GC_FGD, np.where(outer, np.where(mask, cv2.GC_PR_FGD, cv2.GC_PR_BGD),
                                                  cv2.GC_BGD)).astype(np.uint8)
    outside = np.ones((h, w), bool)
    outside[y0:y1, x0:x1] = False
    labels[outside] = cv2.GC_BGD
    radius = max(2, int(round(CLICK_RADIUS * min(x1 - x0, y1 - y0))))
    for x, y, on in clicks:
        cv2.circle(labels, (int(x), int(y)), radius, int(cv2.GC_FGD if on else cv2.GC_BGD), -1)
    undecided = (labels == cv2.GC_PR_FGD) | (labels == cv2.GC_PR_BGD)
    if not undecided.any():
        return np.isin(labels, (cv2.GC_FGD, cv2.GC_PR_FGD))
    # the part of the photo around the band: its colours model the object and what lies beside it
    ys, xs = np.nonzero(outer)
    pad = 8 * r
    cx0, cy0 = max(0, int(xs.min()) - pad), max(0, int(ys.min()) - pad)
    cx1, cy1 = min(w, int(xs.max()) + 1 + pad), min(h, int(ys.max()) + 1 + pad)
    part = np.ascontiguousarray(labels[cy0:cy1, cx0:cx1])
    if np.isin(part, (cv2.GC_FGD, cv2.GC_PR_FGD)).any() and np.isin(part, (cv2.GC_BGD, cv2.GC_PR_BGD)).any():
        cv2.setRNGSeed(0)
        bgd, fgd = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
        cv2.grabCut(cv2.cvtColor(np.ascontiguousarray(photo[cy0:cy1, cx0:cx1]), cv2.COLOR_RGB2BGR), part, None,
                    bgd, fgd, REFINE_ITERATIONS, cv2.GC_INIT_WITH_MASK)
        labels[cy0:cy1, cx0:cx1] = part
    out = (labels == cv2.GC_FGD) | (labels == cv2.GC_PR_FGD)
    n, parts = cv2.connectedComponents(out.astype(np.uint8), connectivity=8)
    keep = {int(parts[y, x]) for x, y, on in clicks if on and 0 <= y < h and 0 <= x < w and parts[y, x] > 0}
    if not keep:
        keep = set(np.unique(parts[inner & out]).tolist()) - {0}
    return np.isin(parts, sorted(keep)) if keep else largest_component(out)


def check_box(spec: str, shape: tuple[int, int]) -> None:
    """One line (InputError) when the box or a click of ``spec`` is not inside a photo of ``shape`` (H, W)."""
    (x0, y0, x1, y1), _ = parse_box(spec)
    h, w = shape
    if x1 <= x0 or y1 <= y0:
        raise InputError(f"--box {spec!r}: X1 must be greater than X0 and Y1 greater than Y0 (the corners are "
                         "top-left, then bottom-right)")
    if not (0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h):
        raise InputError(f"--box {spec!r} is not inside the {w}×{h} photo (need 0 ≤ X0 < X1 ≤ {w}, 0 ≤ Y0 < Y1 ≤ {h})")
    if x1 - x0 < 4 or y1 - y0 < 4:
        raise InputError(f"--box {spec!r} is smaller than 4×4 pixels")
    for x, y, _ in box_clicks(spec):
        if not (0 <= x < w and 0 <= y < h):
            raise InputError(f"--box {spec!r}: the click at {x},{y} is not inside the {w}×{h} photo")


def refine_with_clicks(photo: np.ndarray, box, mask: np.ndarray, clicks) -> np.ndarray:
    """``mask`` (H, W) bool corrected by clicks [(x, y, on the object)]: GrabCut again from the mask as
    probable labels, each click deciding a small disc for certain; then the parts that hold a click on
    the object (or the largest part, when every click is off it). A click off the object is never in it."""
    x0, y0, x1, y1 = box
    init = np.full(photo.shape[:2], cv2.GC_BGD, np.uint8)
    init[y0:y1, x0:x1] = np.where(mask[y0:y1, x0:x1], cv2.GC_PR_FGD, cv2.GC_PR_BGD)
    radius = max(2, int(round(CLICK_RADIUS * min(x1 - x0, y1 - y0))))
    for x, y, on in clicks:
        cv2.circle(init, (int(x), int(y)), radius, int(cv2.GC_FGD if on else cv2.GC_BGD), -1)
    labels = init.copy()
    if np.isin(labels, (cv2.GC_FGD, cv2.GC_PR_FGD)).any() and np.isin(labels, (cv2.GC_BGD, cv2.GC_PR_BGD)).any():
        cv2.setRNGSeed(0)
        bgd, fgd = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
        cv2.grabCut(cv2.cvtColor(photo, cv2.COLOR_RGB2BGR), labels, None, bgd, fgd, GRABCUT_ITERATIONS,
                    cv2.GC_INIT_WITH_MASK)
    out = (labels == cv2.GC_FGD) | (labels == cv2.GC_PR_FGD)
    n, parts = cv2.connectedComponents(out.astype(np.uint8), connectivity=8)
    keep = {int(parts[y, x]) for x, y, on in clicks if on and parts[y, x] > 0}
    out = np.isin(parts, sorted(keep)) if keep else largest_component(out)
    return out


def segment_box(photo: np.ndarray, box: tuple[int, int, int, int], label: str | None = None) -> tuple[np.ndarray, dict]:
    """The object inside ``box`` (x0, y0, x1, y1): (H, W) bool and its :func:`mask_quality` with 'method'.

    For a thing with limbs (:func:`is_limbed`, by its ``label``) GrabCut's mask leaves out the ground
    between its limbs, lit or in shadow (:func:`_without_ground`); what still has the ground's colour
    is measured (``ground_like``) and warned of.

    GrabCut from the box first. When its mask looks like background (the usual failure on a thin object
    lying diagonally: most of the box is background, and GrabCut's colour models cannot tell), two
    refinements are tried and the mask that least looks like background wins: GrabCut started from a band
    along either diagonal of the box (the corners away from it marked background), and a colour model
    that keeps the pixels of the box whose colours are not found around it.
    """
    x0, y0, x1, y1 = box
    bgr = cv2.cvtColor(photo, cv2.COLOR_RGB2BGR)
    limbed = is_limbed(label)
    candidates = {"grabcut": _grabcut(bgr, box, None)}
    best = "grabcut"
    if limbed:
        candidates[best] = _without_ground(photo, box, candidates[best])
    scores = {best: mask_quality(photo, candidates[best], box)}
    if _looks_like_background(scores[best]):
        bw, bh = x1 - x0, y1 - y0
        yy, xx = np.mgrid[0:bh, 0:bw].astype(np.float32)
        for name, (ax, ay, bx, by) in (("diagonal", (0, 0, bw, bh)), ("antidiagonal", (0, bh, bw, 0))):
            # distance of each pixel of the box from the diagonal, in pixels
            dist = np.abs((by - ay) * xx - (bx - ax) * yy + bx * ay - by * ax) / np.hypot(bx - ax, by - ay)
            band = max(2.0, 0.08 * min(bw, bh))
            init = np.full(photo.shape[:2], cv2.GC_BGD, np.uint8)
            inner = np.where(dist <= band, cv2.GC_PR_FGD, np.where(dist <= 3 * band, cv2.GC_PR_BGD, cv2.GC_BGD))
            init[y0:y1, x0:x1] = inner
            candidates[name] = _grabcut(bgr, box, init)
        candidates["colour"] = _colour_model(photo, box)
        for name, m in candidates.items():
            if name not in scores and m.sum() >= MIN_MASK_PIXELS:
                scores[name] = mask_quality(photo, m, box)
        # A box is drawn around the whole object, so a right mask reaches across it; without the span term a
        # short clean fragment of a pencil beats the whole pencil.
        best = min(scores, key=lambda k: scores[k]["background_like"] - scores[k]["edge_agreement"]
                   - 0.5 * _box_span(candidates[k], box))
    quality = dict(scores[best], method=best)
    if limbed:
        quality["ground_like"] = round(float(_ground_like(photo, box, candidates[best]).sum())
                                       / max(1, int(candidates[best].sum())), 4)
        if quality["warning"] is None:
            quality["warning"] = _ground_warning(quality)
    return candidates[best], quality


def _ground_warning(q: dict) -> str | None:
    """The warning of a limbed thing's mask that holds the ground between its legs (``ground_like``), or None."""
    if (q.get("ground_like") or 0.0) <= BACKGROUND_LIKE:
        return None
    return (f"{q['ground_like']:.0%} of the mask has the colour of the ground around its box, in light or shade "
            "(between legs or arms?): click off it there (-X,Y after the --box) or pass a --mask PNG")


def is_limbed(label: str | None) -> bool:
    """Whether a label names a thing with limbs or legs (:data:`LIMBED`; plurals too)."""
    words = re.split(r"[^a-z]+", (label or "").lower())
    return any(w in LIMBED or (w.endswith("s") and w[:-1] in LIMBED) for w in words if w)


def _chroma(pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) r and g shares of r + g + b, and (N,) r + g + b, of RGB ``pixels`` (N, 3)."""
    rgb = pixels.astype(np.float64)
    total = rgb.sum(axis=1)
    return rgb[:, :2] / np.maximum(total, 1.0)[:, None], total


def _ground_like(photo: np.ndarray, box, mask: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels of ``mask`` with a chromaticity common in the band around ``box`` and no
    brighter than that band: its ground, lit or in shadow."""
    x0, y0, x1, y1 = box
    ring = _ring(mask.shape, box, max(4, int(0.15 * max(x1 - x0, y1 - y0))))
    out = np.zeros(mask.shape, bool)
    if ring.sum() < 8 or not mask.any():
        return out
    around = photo[ring]
    around = around[np.random.default_rng(0).permutation(len(around))[:512]]
    chroma, light = _chroma(around)
    keep = light >= DARKEST_CHROMA
    if keep.sum() < 8:
        return out
    tree = cKDTree(chroma[keep])
    ys, xs = np.nonzero(mask)
    c, v = _chroma(photo[ys, xs])
    near = tree.query_ball_point(c, GROUND_CHROMA_DISTANCE, return_length=True)
    like = (near >= max(1, BACKGROUND_SHARE * keep.sum())) & (v >= DARKEST_CHROMA) \
        & (v <= 1.1 * float(np.percentile(light[keep], 95)))
    out[ys[like], xs[like]] = True
    return out


def _without_ground(photo: np.ndarray, box, mask: np.ndarray) -> np.ndarray:
    """``mask`` less the ground it holds (:func:`_ground_like`), specks left out, its largest part kept; the
    mask as it was where that would leave less than half of it (the object itself has the ground's colour)."""
    ground = _ground_like(photo, box, mask)
    ground = cv2.morphologyEx(ground.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)) > 0
    rest = mask & ~ground
    rest = cv2.morphologyEx(rest.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)) > 0
    if rest.sum() < 0.5 * mask.sum():
        return mask
    return largest_component(rest)


def _box_span(mask: np.ndarray, box) -> float:
    """How far ``mask`` reaches across ``box`` (x0, y0, x1, y1): the smaller of its extent's shares of the
    box's width and height, in [0, 1]."""
    x0, y0, x1, y1 = box
    ys, xs = np.nonzero(mask[y0:y1, x0:x1])
    if len(xs) == 0:
        return 0.0
    return float(min((xs.max() - xs.min() + 1) / (x1 - x0), (ys.max() - ys.min() + 1) / (y1 - y0)))


def _grabcut(bgr: np.ndarray, box, init: np.ndarray | None) -> np.ndarray:
    """GrabCut's foreground (largest component), from the rectangle or from ``init`` labels.

    It cuts the whole photo, one box after another in this thread. A window around the box would be faster
    (far background only enlarges the graph) but changes the colour models and the smoothness weight, and so
    the masks by a few per cent (enough to change where the desk example's pushed ball rolls); cuts in other
    threads leave OpenCV's random generator in another state for the plate's shift-map fill, which draws from
    it, and the plate changes from run to run."""
    x0, y0, x1, y1 = box
    cv2.setRNGSeed(0)  # GrabCut's colour models start from k-means: the same box gives the same mask every time
    bgd = np.zeros((1, 65), np.float64)
    fgd = np.zeros((1, 65), np.float64)
    if init is None:
        mask = np.full(bgr.shape[:2], cv2.GC_BGD, np.uint8)
        cv2.grabCut(bgr, mask, (x0, y0, x1 - x0, y1 - y0), bgd, fgd, GRABCUT_ITERATIONS, cv2.GC_INIT_WITH_RECT)
    else:
        mask = init.copy()
        if not np.isin(mask, (cv2.GC_FGD, cv2.GC_PR_FGD)).any():
            return np.zeros(bgr.shape[:2], bool)
        cv2.grabCut(bgr, mask, None, bgd, fgd, GRABCUT_ITERATIONS, cv2.GC_INIT_WITH_MASK)
    return largest_component((mask == cv2.GC_FGD) | (mask == cv2.GC_PR_FGD))


def _ring(shape, box, width: int) -> np.ndarray:
    """(H, W) bool: a band ``width`` pixels wide just outside ``box``."""
    h, w = shape
    x0, y0, x1, y1 = box
    out = np.zeros((h, w), bool)
    out[max(0, y0 - width):min(h, y1 + width), max(0, x0 - width):min(w, x1 + width)] = True
    out[y0:y1, x0:x1] = False
    return out


def _background_colours(lab: np.ndarray, box, mask: np.ndarray | None = None,
                        others: np.ndarray | None = None) -> np.ndarray:
    """(K, 3) float32: colours (CIELab) of the background of ``box``: the band around it and, given the
    object's ``mask``, the part of the box away from it, less ``others`` (H, W) bool (other objects); empty when
    there is none."""
    x0, y0, x1, y1 = box
    width = max(4, int(0.15 * max(x1 - x0, y1 - y0)))
    region = _ring(lab.shape[:2], box, width)
    if mask is not None:
        rest = np.zeros_like(region)
        rest[y0:y1, x0:x1] = True
        region |= rest & ~cv2.dilate(mask.astype(np.uint8), np.ones((7, 7), np.uint8)).astype(bool)
    if others is not None:
        region &= ~others
    pixels = lab[region].astype(np.float32)
    if len(pixels) < 8:
        return np.zeros((0, 3), np.float32)
    return pixels[np.random.default_rng(0).permutation(len(pixels))[:512]]


def _background_like(lab: np.ndarray, pixels: np.ndarray, colours: np.ndarray) -> np.ndarray:
    """(N,) bool: which of ``pixels`` (N, 3) Lab have a colour common among ``colours`` (within the background
    distance of at least :data:`BACKGROUND_SHARE` of them)."""
    if len(colours) == 0 or len(pixels) == 0:
        return np.zeros(len(pixels), bool)
    weight = np.array([0.5, 1.0, 1.0], np.float32)  # lightness counts half: shading varies across a surface
    # a k-d tree over the few hundred background colours counts each pixel's neighbours in one query; it
    # counts those at the radius too, and Lab's whole numbers sit there often: just under it is "within"
    tree = cKDTree(colours.astype(np.float64) * weight)
    near = tree.query_ball_point(pixels.astype(np.float64) * weight, np.nextafter(BACKGROUND_COLOUR_DISTANCE, 0),
                                 return_length=True)
    return near >= max(1, BACKGROUND_SHARE * len(colours))


def _colour_model(photo: np.ndarray, box) -> np.ndarray:
    """The pixels of ``box`` whose colours are not found around it, closed and reduced to the largest part."""
    x0, y0, x1, y1 = box
    lab = cv2.cvtColor(photo, cv2.COLOR_RGB2Lab)
    colours = _background_colours(lab, box)
    inside = lab[y0:y1, x0:x1].reshape(-1, 3)
    fg = ~_background_like(lab, inside, colours).reshape(y1 - y0, x1 - x0)
    fg = cv2.morphologyEx(fg.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    fg = cv2.morphologyEx(fg, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8)) > 0
    out = np.zeros(photo.shape[:2], bool)
    out[y0:y1, x0:x1] = fg
    return largest_component(out) if out.any() else out


def mask_quality(photo: np.ndarray, mask: np.ndarray, box=None, others: np.ndarray | None = None) -> dict:
    """How far ``mask`` (H, W) bool can be trusted, measured against the photo (H, W, 3) uint8 RGB.

    box_fraction: the mask's share of its box (``box`` (x0, y0, x1, y1), default its bounding box, kept as
    ``box``); edge_agreement: the share of its outline within 2 pixels of an edge of the photo (Canny), beyond
    the share expected by chance from the density of edges around it (0 for an outline that ignores them);
    background_like: the share of its pixels whose colour is one of those around the box; round_missing: see
    :func:`_round_missing`. ``others`` (H, W) bool, the other objects' masks where they are known: their pixels
    are not background, the outline along them is theirs, and what of a round outline they cover they hide
    (:data:`OCCLUDER_REACH`). ``warning`` says what looks wrong, or is None.
    """
    ys, xs = np.nonzero(mask)
    if box is None:
        box = (int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1)
    x0, y0, x1, y1 = box
    along = None if others is None or not others.any() else cv2.dilate(
        others.astype(np.uint8), np.ones((2 * OCCLUDER_REACH + 1,) * 2, np.uint8)).astype(bool)
    near = None if along is None else along & ~mask
    grey = cv2.GaussianBlur(cv2.cvtColor(photo, cv2.COLOR_RGB2GRAY), (3, 3), 0)
    # Canny thresholds from the photo's own gradients, so that faint and strong photos compare alike
    mag = np.hypot(cv2.Sobel(grey, cv2.CV_32F, 1, 0), cv2.Sobel(grey, cv2.CV_32F, 0, 1))
    high = max(20.0, float(np.percentile(mag, 90)))
    edges = cv2.dilate(cv2.Canny(grey, 0.5 * high, high), np.ones((5, 5), np.uint8)) > 0
    m8 = mask.astype(np.uint8)
    outline = (m8 - cv2.erode(m8, np.ones((3, 3), np.uint8))) > 0
    # the image border is not an edge of the object
    outline[[0, -1], :] = False
    outline[:, [0, -1]] = False
    if along is not None and (outline & ~along).sum() >= MIN_MASK_PIXELS:
        outline &= ~along  # along another object the edge is that object's, or none where the two look alike
    # beyond chance: on a textured surface any outline crosses some edges
    ring = _ring(mask.shape, box, max(4, int(0.15 * max(x1 - x0, y1 - y0))))
    density = float(edges[ring].mean()) if ring.any() else 0.0
    edge = float(edges[outline].mean()) if outline.any() else 0.0
    edge = max(0.0, (edge - density) / max(1e-6, 1.0 - density)) if density < 1.0 else 0.0
    lab = cv2.cvtColor(photo, cv2.COLOR_RGB2Lab)
    colours = _background_colours(lab, box, mask, near)
    sample = lab[ys, xs][:: max(1, len(ys) // 5000)]
    like = float(_background_like(lab, sample, colours).mean()) if len(sample) else 1.0
    area = max(1, (x1 - x0) * (y1 - y0))
    out = {"box_fraction": round(float(mask[y0:y1, x0:x1].sum()) / area, 4), "edge_agreement": round(edge, 4),
           "background_like": round(like, 4), "round_missing": _round_missing(mask, near),
           "box": [int(v) for v in box]}
    out["warning"] = _warning(out)
    return out


def _round_missing(mask: np.ndarray, hidden: np.ndarray | None = None) -> float | None:
    """For a round outline (its convex hull's circularity at least :data:`ROUND_CIRCULARITY`), the share of
    the hull the mask leaves out (holes, bites) where ``hidden`` (H, W) bool (what other objects cover) does not
    explain it; None for any other outline."""
    if int(np.count_nonzero(mask)) < MIN_MASK_PIXELS:
        return None
    hull = cv2.convexHull(hull_points(mask))
    filled = np.zeros(mask.shape, np.uint8)
    cv2.fillPoly(filled, [hull], 1)
    area, perimeter = float(filled.sum()), cv2.arcLength(hull, True)
    if perimeter <= 0 or 4 * np.pi * area / perimeter ** 2 < ROUND_CIRCULARITY:
        return None
    missing = filled.astype(bool) & ~mask
    if hidden is not None:
        missing &= ~hidden
    return round(float(missing.sum()) / area, 4)


def _looks_like_background(q: dict) -> bool:
    return q["background_like"] > BACKGROUND_LIKE or q["edge_agreement"] < MIN_EDGE_AGREEMENT


def _warning(q: dict) -> str | None:
    if q["background_like"] > BACKGROUND_LIKE:
        return (f"{q['background_like']:.0%} of the mask has the colours around it: it looks like background; "
                "pass a --mask PNG or a tighter --box")
    if q["edge_agreement"] < MIN_EDGE_AGREEMENT:
        return (f"only {q['edge_agreement']:.0%} of the mask's outline follows an edge of the photo; "
                "check masks.png")
    if (q.get("round_missing") or 0.0) > ROUND_MISSING:
        return (f"the outline is round but the mask leaves out {q['round_missing']:.0%} of it (holes or bites, "
                "e.g. a ball's dark panels): click on the missing parts (+X,Y after the --box) or pass a "
                "--mask PNG")
    return None


def qualify_among(photo: np.ndarray, objects) -> None:
    """Each object's :func:`mask_quality` warning measured again with the other ``objects``' masks known
    (their union as ``others``), in place: the warnings are for a box or clicks that took in background or
    missed a part, and a mask hidden in part by an object in front of it (a box behind a box, a ball behind a
    cup) has a bite, a box with another object in it and an outline along that object's that no such mistake
    made. A warning the others do not explain stays."""
    for o in objects:
        q = o.quality
        if not q or not q.get("warning") or "background_like" not in q or q["warning"] != _warning(q):
            continue  # no warning, or one mask_quality did not give (the ground between legs)
        others = np.zeros(o.mask.shape, bool)
        for other in objects:
            if other is not o and other.mask.shape == o.mask.shape:
                others |= other.mask
        if not others.any():
            continue
        again = mask_quality(photo, o.mask, q.get("box"), others)
        o.quality = dict(q, **again)
        if o.quality["warning"] is None:
            o.quality["warning"] = _ground_warning(o.quality)


def contact_sheet(photo: np.ndarray, objects, completed=None) -> np.ndarray:
    """(H, W, 3) uint8: the photo, dimmed, with each object's mask tinted in its own colour, outlined, and
    labelled with its name (and a warning mark when its quality says so). ``completed``: each object's
    outline completed behind what hides it, (H, W) bool, drawn as a thin line in its colour."""
    out = photo.astype(np.float32) * 0.55
    h, w = photo.shape[:2]
    scale = max(0.35, min(h, w) / 700.0)
    colours = []
    for i, o in enumerate(objects):
        hue = int(179 * ((i * 0.618) % 1.0))
        colour = cv2.cvtColor(np.uint8([[[hue, 220, 255]]]), cv2.COLOR_HSV2RGB)[0, 0].astype(np.float32)
        out[o.mask] = 0.5 * photo[o.mask].astype(np.float32) + 0.5 * colour
        colours.append(tuple(int(c) for c in colour))
    out = np.clip(out + 0.5, 0, 255).astype(np.uint8)
    for o, colour in zip(objects, colours):
        contours, _ = cv2.findContours(o.mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(out, contours, -1, colour, max(1, int(round(2 * scale))))
    for o, colour, whole in zip(objects, colours, completed or [None] * len(objects)):
        if whole is not None and (whole & ~o.mask).any():
            contours, _ = cv2.findContours(whole.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
            cv2.drawContours(out, contours, -1, colour, 1, cv2.LINE_AA)
    for o, colour in zip(objects, colours):
        ys, xs = np.nonzero(o.mask)
        text = o.name + (" (?)" if o.quality and o.quality.get("warning") else "")
        org = (int(xs.min()), max(int(14 * scale) + 2, int(ys.min()) - 4))
        cv2.putText(out, text, org, cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale, (0, 0, 0), max(1, int(3 * scale)),
                    cv2.LINE_AA)
        cv2.putText(out, text, org, cv2.FONT_HERSHEY_SIMPLEX, 0.5 * scale, colour, max(1, int(scale)), cv2.LINE_AA)
    return out


def largest_component(mask: np.ndarray) -> np.ndarray:
    """The largest 8-connected component of a boolean mask (the mask itself if it is empty)."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 2:
        return mask
    keep = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return labels == keep


def checked_mask(mask: np.ndarray, what: str) -> np.ndarray:
    """``mask`` (H, W) bool, or one line (InputError) naming ``what`` when it is empty, tiny or the whole photo."""
    count = int(mask.sum())
    if count == 0:
        raise InputError(f"{what} is empty: no pixel belongs to the object")
    if count < MIN_MASK_PIXELS:
        raise InputError(f"{what} has only {count} pixels; an object needs at least {MIN_MASK_PIXELS}")
    if count == mask.size:
        raise InputError(f"{what} covers the whole photo; nothing would be left for the ground and background")
    return mask


def collect_masks(photo: np.ndarray, mask_specs, box_specs, progress=None) -> list[ObjectMask]:
    """All objects, numbered in the order given: masks first, then boxes. ``progress(done, total)`` is told
    after each box's mask is cut (GrabCut takes seconds a box on a large photo)."""
    specs = list(mask_specs or ())
    boxes = list(box_specs or ())
    if not specs and not boxes:
        raise InputError("no objects given: pass --mask PNG[:LABEL], --box X0,Y0,X1,Y1[:LABEL] or --find PHRASES "
                         "at least once (or pick them in the browser: physomni-usd studio PHOTO -o DIR)")
    shape = photo.shape[:2]
    objects = [read_mask(s, shape, i) for i, s in enumerate(specs)]
    for j, s in enumerate(boxes):
        objects.append(mask_from_box(photo, s, len(specs) + j))
        if progress is not None:
            progress(j + 1, len(boxes))
    for o in objects:
        if o.quality is not None and "edge_agreement" not in o.quality:
            o.quality = dict(mask_quality(photo, o.mask), method=o.quality["method"])
    return objects
