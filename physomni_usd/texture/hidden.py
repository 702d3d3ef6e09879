"""The surfaces of an object that the photo hides: which of them are painted, and how.

Where another object hides part of one (``perceive/amodal.py`` completes its outline there), that part is
painted from the object's own visible surface (:func:`complete_texture`), never from the occluder's or the
background's pixels, so that a saucer the cup leaves is whole. It is painted only behind occluders that the
placed meshes agree are in front of it (:func:`occlusion_kept`, :data:`OCCLUSION_BELIEVED`), and at an alpha
(:data:`COMPLETED_ALPHA`) that tells renderers it is not the photo's own pixels of the object.
"""

from __future__ import annotations

import cv2
import numpy as np

#: Texture alpha of what is painted behind an object's occluders: opaque to every renderer's cut-out, yet not
#: 255, the alpha of the pixels the photo shows of the object.
COMPLETED_ALPHA = 254
#: An occluder the placed meshes put in front of the object at fewer than this fraction of the pixels where the
#: photo shows it hiding it (:func:`occlusion_kept`) hides nothing of it: nothing is painted behind it (a big
#: concave object's closure takes in the bench behind it; painted, that is a grey slab once it moves).
OCCLUSION_BELIEVED = 0.5
#: Width, as a fraction of the image's longer side (at least :data:`EDGE_BAND_MIN` pixels), of the band of an
#: object's visible pixels along what hides it that :func:`complete_texture` neither takes colours from nor
#: keeps: anti-aliasing, the mask's own error and the occluder's contact shadow darken it.
EDGE_BAND = 0.005
EDGE_BAND_MIN = 2


def edge_band(visible: np.ndarray, hidden: np.ndarray, longer: int | None = None) -> np.ndarray:
    """(H, W) bool: the object's ``visible`` pixels along its ``hidden`` part, :data:`EDGE_BAND` of the image's
    longer side wide (``longer``: the whole photo's, when the masks are a part of it)."""
    longer = max(visible.shape) if longer is None else longer
    band = max(EDGE_BAND_MIN, int(round(EDGE_BAND * longer)))
    if not hidden.any():
        return np.zeros_like(visible)
    # found in the hidden part's box grown by the band only: a pixel beyond it is farther than the band (the
    # distance is at least the chessboard one), and the nearest path to one inside stays inside
    ys, xs = np.nonzero(hidden.any(1))[0], np.nonzero(hidden.any(0))[0]
    h, w = hidden.shape
    box = (slice(max(0, ys[0] - band - 1), min(h, ys[-1] + band + 2)),
           slice(max(0, xs[0] - band - 1), min(w, xs[-1] + band + 2)))
    out = np.zeros_like(visible)
    out[box] = visible[box] & (cv2.distanceTransform((~hidden[box]).astype(np.uint8), cv2.DIST_L2, 5) <= band)
    return out


def complete_texture(photo: np.ndarray, visible: np.ndarray, amodal: np.ndarray,
                     longer: int | None = None, step: float = 1.0) -> np.ndarray:
    """The photo (H, W, 3) uint8 with the hidden part of one object (``amodal`` but not ``visible``) painted
    from that object's own visible pixels: each hidden pixel takes the colour of the nearest visible one
    beyond the occluder's edge (:func:`edge_band`), softened across the fill so that no seam of single pixels
    is repeated (over 2 % of the image's longer side; ``longer``: the whole photo's, when ``photo`` is a part
    of it). The visible pixels along the edge are painted the same way: the photo mixes the occluder's
    colours and its contact shadow into them, and once the occluder leaves they ring the fill. With ``step``
    over 1 (photo pixels per working pixel, a photo above the working resolution), the fill is found on a copy
    reduced by ``step`` and carried up: softened over 2 % of the image, it holds no detail a reduced copy lacks."""
    hidden = amodal & ~visible
    if not hidden.any() or not visible.any():
        return photo.copy()
    longer = max(visible.shape) if longer is None else longer
    r = max(1, int(round(0.02 * longer)))
    # a coin's dark rim on a white card, taken as the card's nearest colour, fills the coin's place grey
    edge = edge_band(visible, hidden, longer)
    source = visible & ~edge
    if not source.any():
        source, edge = visible, np.zeros_like(visible)
    painted = hidden | edge
    soft = _soft_fill_reduced(photo, source, amodal, r, step, painted) if step > 1.0 else None
    if soft is None:
        soft = _soft_fill(photo, source, amodal.astype(np.float32), r)[painted]
    out = photo.copy()
    out[painted] = np.clip(soft + 0.5, 0, 255).astype(np.uint8)
    return out


def _soft_fill(photo: np.ndarray, source: np.ndarray, amodal: np.ndarray, r: int) -> np.ndarray:
    """(H, W, 3) float32: each pixel the colour of the nearest ``source`` pixel, averaged over a box of radius
    ``r`` within ``amodal`` (H, W) float32, the share of each pixel inside the outline."""
    # labels of the nearest zero pixel: the zeros are the sources, so colours come from the object beyond its edge
    _, labels = cv2.distanceTransformWithLabels((~source).astype(np.uint8), cv2.DIST_L2, 5,
                                                labelType=cv2.DIST_LABEL_PIXEL)
    ys, xs = np.nonzero(source)
    colour_of = np.zeros((int(labels.max()) + 1, 3), np.float32)
    colour_of[labels[ys, xs]] = photo[ys, xs]
    filled = colour_of[labels]
    weight = cv2.blur(amodal, (2 * r + 1, 2 * r + 1))
    return cv2.blur(filled * amodal[..., None], (2 * r + 1, 2 * r + 1)) / np.maximum(weight, 1e-6)[..., None]


def _soft_fill_reduced(photo: np.ndarray, source: np.ndarray, amodal: np.ndarray, r: int,
                       step: float, at: np.ndarray) -> np.ndarray | None:
    """:func:`_soft_fill` found on a copy reduced by ``step`` and brought back to the photo's size at the pixels
    ``at`` (H, W) bool only, (n, 3) float32 in their row-major order; None where no reduced pixel lies wholly in
    ``source``. A reduced pixel is a source only where all of it is one (its colour then the object's alone),
    and the outline weighs each by the share of it inside."""
    h, w = source.shape
    size = (max(1, int(round(w / step))), max(1, int(round(h / step))))
    # the source's share and the outline's in one reduction
    shares = cv2.resize(np.dstack([source, amodal]).astype(np.float32), size, interpolation=cv2.INTER_AREA)
    share, inside = shares[..., 0], np.ascontiguousarray(shares[..., 1])
    small_source = share >= 1.0 - 1e-4
    if not small_source.any():
        return None
    small = cv2.resize(photo, size, interpolation=cv2.INTER_AREA)
    soft = _soft_fill(small, small_source, inside, max(1, int(round(r / step))))
    ys, xs = np.nonzero(at)
    return _linear_at(soft, (w, h), ys, xs)


def _linear_at(small: np.ndarray, size: tuple[int, int], ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """(n, C) float32: ``small`` (h, w, C) float32 brought to ``size`` (W, H) as ``cv2.resize`` with
    ``INTER_LINEAR`` brings it (pixel centres aligned, the edge pixel held), at the pixels (``ys``, ``xs``) only:
    a 12 MP photo's part brought up whole cost half a second for the few pixels that are painted."""
    sh, sw = small.shape[:2]
    W, H = size

    def taps(d, big, n):
        f = ((d + 0.5) * (n / big) - 0.5).astype(np.float32)
        i = np.floor(f).astype(np.int64)
        t = f - i
        low, high = i < 0, i >= n - 1
        t[low | high] = 0.0
        i = np.clip(i, 0, n - 1)
        return i, np.minimum(i + 1, n - 1), t.astype(np.float32)

    x0, x1, fx = taps(xs, W, sw)
    y0, y1, fy = taps(ys, H, sh)
    fx, fy = fx[:, None], fy[:, None]
    top = small[y0, x0] * (1.0 - fx) + small[y0, x1] * fx
    bottom = small[y1, x0] * (1.0 - fx) + small[y1, x1] * fx
    return (top * (1.0 - fy) + bottom * fy).astype(np.float32)


def painted_part(visible: np.ndarray, amodal: np.ndarray, disbelieved: list[np.ndarray]) -> np.ndarray:
    """(H, W) bool: the part of an object's completed outline ``amodal`` that is painted in its texture, the
    hidden part (not ``visible``) less the pixels of each occluder whose occlusion the placed meshes do not
    keep (``disbelieved``: those occluders' visible masks, (H, W) bool each)."""
    hidden = amodal & ~visible
    for mask in disbelieved:
        hidden &= ~mask
    return hidden


def believed(kept: float | None) -> bool:
    """Whether an occluder hides the object as the photo shows it, from its :func:`occlusion_kept` (None: no ray
    met the occluder, which says nothing against it)."""
    return kept is None or kept >= OCCLUSION_BELIEVED


def occlusion_kept(camera, front, behind, pixels: np.ndarray, samples: int = 200, seed: int = 0) -> float | None:
    """Fraction of ``pixels`` (n, 2: x, y) where the photo shows ``front`` hiding ``behind`` and the placed
    meshes agree: the ray through the pixel meets ``front`` (a ``trimesh.Trimesh``, world metres) before
    ``behind``, or misses ``behind``. None where no ray meets ``front``; at most ``samples`` pixels are cast."""
    pixels = np.asarray(pixels, float)
    if len(pixels) > samples:
        pixels = pixels[np.random.default_rng(seed).choice(len(pixels), samples, replace=False)]
    if not len(pixels):
        return None
    dirs = camera.rays(pixels[:, 0] + 0.5, pixels[:, 1] + 0.5)
    origins = np.repeat(camera.origin[None], len(dirs), 0)

    def first_hit(mesh):
        out = np.full(len(dirs), np.inf)
        hits, ray, _ = mesh.ray.intersects_location(origins, dirs, multiple_hits=False)
        if len(ray):  # with no hit trimesh answers a flat empty array, which has no rows to measure
            out[ray] = np.linalg.norm(np.reshape(hits, (-1, 3)) - camera.origin, axis=1)
        return out

    near, far = first_hit(front), first_hit(behind)
    seen = np.isfinite(near)
    if not seen.any():
        return None
    return float((near[seen] <= far[seen]).mean())
