"""Small image operations the texture stage's fills share: blurs over part of an image, distances to a
mask, growing a mask, a gradient, and the radius of OpenCV's Telea fill."""

from __future__ import annotations

import cv2
import numpy as np

#: Inpainting radius of OpenCV's Telea method, pixels.
INPAINT_RADIUS = 5


def gradient(grey: np.ndarray) -> np.ndarray:
    """(h, w) float32 Sobel gradient magnitude of ``grey`` (the measure ``bench look`` holds a fill to)."""
    return np.hypot(cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3))


def blur(img: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur of float32 ``img`` by ``sigma`` pixels; wide blurs are done on a reduced copy (same result
    to within the reduction's interpolation, a fraction of the time)."""
    img = np.asarray(img, np.float32)
    k = int(sigma // 4)
    if k < 2:
        return cv2.GaussianBlur(img, (0, 0), sigma)
    h, w = img.shape[:2]
    small = cv2.resize(img, (max(1, w // k), max(1, h // k)), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), sigma / k)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)


def blur_over(img: np.ndarray, weight: np.ndarray, sigma: float) -> np.ndarray:
    """``img`` (h, w) or (h, w, C) blurred by ``sigma`` pixels over the pixels that ``weight`` (h, w) float32
    holds alone: what lies outside them (a hole, an object) takes no part in the mean."""
    total = np.maximum(blur(weight, sigma), 1e-3)
    if img.ndim == 3:
        return blur(img * weight[..., None], sigma) / total[..., None]
    return blur(img * weight, sigma) / total


def within(mask: np.ndarray, r: float) -> np.ndarray:
    """Pixels within ``r`` pixels of ``mask`` (a distance transform: fast for any ``r``)."""
    return cv2.distanceTransform((~np.asarray(mask, bool)).astype(np.uint8), cv2.DIST_L2, 5) <= r


def dilate(mask: np.ndarray, r: int) -> np.ndarray:
    """``mask`` grown by a disc of radius ``r`` pixels."""
    if r <= 0:
        return np.asarray(mask, bool).copy()
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return cv2.dilate(np.asarray(mask, np.uint8), kernel) > 0


#: The surroundings of a hole whose colours a fill may use: the known pixels within this fraction of the image
#: diagonal (at least 8 pixels) of each connected part of the hole.
SURROUND = 0.05


def nearest_surrounding(image: np.ndarray, hole: np.ndarray, reach: float | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
    """For each pixel of ``hole`` (H, W) bool, the colour of the known pixels (not ``hole``) within ``reach``
    pixels of its connected part (default :data:`SURROUND` of the diagonal) nearest to its own colour in ``image``
    (H, W, 3) uint8, and the RGB distance (levels) to it: (H, W, 3) float32 and (H, W) float32, the pixel's own
    colour and 0 outside the hole, and its own colour and inf in a part with no known pixel around it. The one
    measure both of the colour cap of the fill and of the bench that scores it."""
    from scipy.spatial import cKDTree

    hole = np.asarray(hole, bool)
    h, w = hole.shape
    if reach is None:
        reach = max(8.0, SURROUND * float(np.hypot(h, w)))
    nearest = image.astype(np.float32)
    dist = np.zeros((h, w), np.float32)
    # colours as one integer each: unique colours of a 12 MP photo's ring sort as a flat array in a fraction of
    # the time rows take, and each part's pixels are looked up once per colour, not once per pixel
    code = colour_code(image)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(hole.astype(np.uint8), connectivity=8)
    grow = int(np.ceil(reach)) + 1
    for k in range(1, n):
        # the part's box grown by the reach: nothing farther can be within it
        x, y, bw, bh = stats[k, :4]
        box = (slice(max(0, y - grow), min(h, y + bh + grow)), slice(max(0, x - grow), min(w, x + bw + grow)))
        part = labels[box] == k
        ring = within(part, reach) & ~hole[box]
        if not ring.any():
            dist[box][part] = np.inf
            continue
        colours = _colour_of(np.unique(code[box][ring]))
        own, back = np.unique(code[box][part], return_inverse=True)
        d, idx = cKDTree(colours).query(_colour_of(own))
        dist[box][part] = d[back.reshape(-1)]
        nearest[box][part] = colours[idx[back.reshape(-1)]]
    return nearest, dist


def colour_code(image: np.ndarray) -> np.ndarray:
    """(H, W) int32: each pixel's colour of ``image`` (H, W, 3) uint8 as one integer (a key to sort, match or
    count colours by; :func:`_colour_of` turns it back)."""
    c = image.astype(np.int32)
    return (c[..., 0] << 16) | (c[..., 1] << 8) | c[..., 2]


def _colour_of(code: np.ndarray) -> np.ndarray:
    """(n, 3) float32 colours of :func:`colour_code`'s integers."""
    return np.stack([(code >> 16) & 255, (code >> 8) & 255, code & 255], axis=-1).astype(np.float32)
