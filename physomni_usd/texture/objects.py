"""Each object's texture: its crop of the photo, completed behind what hides it, and where its mesh takes it.

The crop (:func:`crop_texture`) is cut out by the object's mask and its colours pushed past the edge; where
others hide it, the hidden part is painted from its own visible surface (``hidden.py``); the texture file
holds that crop beside an opaque copy for the sides the photo saw edge-on, and the texture coordinates
project the photo from its camera onto the object (``sides.py``). :func:`texture_object` does all of it for
one placed object, at the photo's own size when the build worked on a reduced copy.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .hidden import COMPLETED_ALPHA, complete_texture, edge_band
from .sides import corner_st, two_sided_texture

#: Pixels of photo kept around an object's mask in its crop (:func:`crop_texture`).
PAD = 8


@dataclass
class ObjectTexture:
    """One object's texture: ``rgba`` (h, 2w, 4) uint8, the photo's crop beside its opaque copy
    (:func:`~.sides.two_sided_texture`); ``st`` (F·3, 2) faceVarying texture coordinates into it; ``origin``
    (x0, y0), the crop's corner in the photo's pixels."""

    rgba: np.ndarray
    st: np.ndarray
    origin: tuple[int, int]


def texture_object(photo: np.ndarray, camera, visible: np.ndarray, amodal: np.ndarray, painted: np.ndarray,
                   projected: np.ndarray, faces: np.ndarray, open_back: bool = False, work=None) -> ObjectTexture:
    """The texture of one placed object.

    ``photo`` (H, W, 3) uint8 seen by ``camera`` (a :class:`~physomni_usd.geometry.camera.PinholeCamera` over its
    pixels); ``visible`` and ``amodal`` (H, W) bool, its mask and its outline completed behind its occluders
    (:func:`at_photo_size`); ``painted`` (H, W) bool, the part of the hidden outline that is painted
    (:func:`~.hidden.painted_part`: the rest of it is transparent); ``projected`` (N, 3) world metres, its
    vertices where the photo saw them, and ``faces`` (F, 3); ``open_back``: the faces turned away from the
    camera see through (a slab's back, :func:`~.sides.corner_st`); ``work``: the
    :class:`~physomni_usd.perceive.working.Working` copy the build worked on, if any (the crop is then worked on
    the object's part of the photo only, and the opaque copy found on a reduced copy)."""
    rgba, (x0, y0) = completed_crop(photo, visible, amodal, part_only=work is not None,
                                   step=1.0 if work is None else min(work.fx, work.fy))
    # drawn like the rest, but not the photo's pixels of it: renderers show the photo only at 255
    crop = (slice(y0, y0 + rgba.shape[0]), slice(x0, x0 + rgba.shape[1]))
    rgba[..., 3][(amodal & ~visible & ~painted)[crop]] = 0  # behind what the meshes put behind it
    rgba[..., 3][painted[crop]] = COMPLETED_ALPHA
    # its rim along what is painted is repainted too (complete_texture): not the photo's pixels of it either,
    # so that a frame shows it from the texture, not the photo's occluder edge, once the occluder has moved
    # (found on the crop alone: all that is painted lies in it, and so does every nearest path to it)
    rgba[..., 3][edge_band(visible[crop], painted[crop], max(photo.shape[:2]))] = COMPLETED_ALPHA
    # texture coordinates: the photo projected from the camera onto the object where it was seen, and
    # a planar map for the sides it saw edge-on (sides.py)
    st = corner_st(projected, np.asarray(faces), camera, (rgba.shape[1], rgba.shape[0]), (x0, y0),
                   mask=rgba[..., 3] > 0, open_back=open_back)
    return ObjectTexture(two_sided_texture(rgba, 1.0 if work is None else work.fx), st, (x0, y0))


def completed_crop(photo: np.ndarray, visible: np.ndarray, amodal: np.ndarray, part_only: bool = False,
                   step: float = 1.0):
    """:func:`crop_texture` of the object completed behind its occluders (:func:`~.hidden.complete_texture`),
    and its (x0, y0) in the photo; with ``part_only`` (a photo above the working resolution), worked on the
    object's part of the photo only (the padding :data:`PAD` and the completion's softening reach, kept the
    whole photo's) and its fill found on a copy reduced by ``step`` (photo pixels per working pixel)."""
    if not part_only:
        return crop_texture(complete_texture(photo, visible, amodal), amodal)
    ys, xs = np.nonzero(amodal)
    h, w = amodal.shape
    x0, x1 = max(0, xs.min() - PAD), min(w, xs.max() + PAD + 1)
    y0, y1 = max(0, ys.min() - PAD), min(h, ys.max() + PAD + 1)
    part = (slice(y0, y1), slice(x0, x1))
    rgba, (cx, cy) = crop_texture(complete_texture(photo[part], visible[part], amodal[part], max(h, w), step),
                                  amodal[part])
    return rgba, (int(x0 + cx), int(y0 + cy))


def at_photo_size(work, mask: np.ndarray, amodal: np.ndarray, full_mask: np.ndarray | None = None):
    """(H, W) bool at the photo's size: an object's mask (``full_mask``, a mask file's own, else the working
    ``mask`` smoothed up) and its outline completed behind its occluders (that mask, and the working completion
    ``amodal`` where it is hidden); ``mask`` and ``amodal`` as they are where ``work`` is None (the build worked
    on the photo itself)."""
    if work is None:
        return mask, amodal
    visible = full_mask if full_mask is not None else work.up_mask(mask)
    hidden = amodal & ~mask
    if not hidden.any():
        return visible, visible
    # a working pixel wider than the hidden part, so that it meets the visible edge with no gap between them
    hidden = cv2.dilate(hidden.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool) & amodal
    return visible, visible | work.up_mask(hidden)


def crop_texture(photo: np.ndarray, mask: np.ndarray, pad: int = PAD) -> tuple[np.ndarray, tuple[int, int]]:
    """RGBA crop of one object, (h, w, 4) uint8, and its (x0, y0) offset in the photo.

    Alpha is the mask, so renderers cut the object out exactly; colours are
    pushed outward past the mask's edge so that filtered lookups at the border
    never pick up the background.
    """
    ys, xs = np.nonzero(mask)
    H, W = mask.shape
    x0, x1 = max(0, xs.min() - pad), min(W, xs.max() + 1 + pad)
    y0, y1 = max(0, ys.min() - pad), min(H, ys.max() + 1 + pad)
    rgb = photo[y0:y1, x0:x1].copy()
    m = mask[y0:y1, x0:x1].astype(np.uint8)
    rgb = extend_colours(rgb, m, pad)
    alpha = (m * 255).astype(np.uint8)
    return np.dstack([rgb, alpha]), (int(x0), int(y0))


def extend_colours(rgb: np.ndarray, mask: np.ndarray, steps: int) -> np.ndarray:
    """Grow the colours inside ``mask`` outward by ``steps`` pixels (mean of known neighbours).

    Step k reaches the pixels k from the mask (chessboard distance), each the mean of its neighbours reached
    before it. Only those rings are worked on, and only they are held as floats: a 12 MP photo's crop taken
    whole to floats, or compared whole at each step, cost seconds; every other pixel is the photo's own."""
    known = mask.astype(bool)
    if known.all() or not known.any():
        return rgb.copy()
    h, w = known.shape
    # the distance grown at, padded by one so that a pixel's eight neighbours are always addressable
    ring = np.full((h + 2, w + 2), np.inf, np.float32)
    ring[1:-1, 1:-1] = cv2.distanceTransform((~known).astype(np.uint8), cv2.DIST_C, 3)
    ys, xs = np.nonzero((ring >= 1) & (ring <= steps))
    k_of = ring[ys, xs]
    order = np.argsort(k_of, kind="stable")
    ys, xs, k_of = ys[order], xs[order], k_of[order]
    # each grown pixel's float colour, found through its index; a neighbour not grown is the photo's own
    values = np.zeros((len(ys), rgb.shape[2]), np.float32)
    index = np.full((h + 2, w + 2), -1, np.int32)
    index[ys, xs] = np.arange(len(ys), dtype=np.int32)
    offsets = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    bounds = np.searchsorted(k_of, np.arange(1, steps + 2), side="left")
    for k in range(1, steps + 1):
        lo, hi = bounds[k - 1], bounds[k]
        if lo == hi:
            break
        y, x = ys[lo:hi], xs[lo:hi]
        total = np.zeros((hi - lo, rgb.shape[2]), np.float32)
        count = np.zeros(hi - lo, np.float32)
        for dy, dx in offsets:
            ny, nx = y + dy, x + dx
            before = ring[ny, nx] < k
            at = index[ny, nx]
            # a neighbour off the crop is never reached before (its distance is infinite): any pixel will do
            colour = rgb[np.clip(ny - 1, 0, h - 1), np.clip(nx - 1, 0, w - 1)].astype(np.float32)
            grown = at >= 0
            colour[grown] = values[at[grown]]
            total += colour * before[:, None]
            count += before
        values[lo:hi] = total / count[:, None]
    out = rgb.copy()
    out[ys - 1, xs - 1] = np.clip(values + 0.5, 0, 255).astype(np.uint8)
    return out
