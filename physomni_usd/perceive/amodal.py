"""Who hides whom in the photo, and each hidden object's outline completed behind what hides it.

Owns the occlusion order and the amodal completion that ``build`` runs between
segmenting and lifting. A user's or a segmenter's mask is the object's
*visible* part. Where two masks meet, the occluder's outline is whole and the
occluded one's is cut: the occluded object's convex closure reaches into the
occluder's pixels, the occluder's does not reach into it. The hidden part is
then completed by an ellipse where the visible outline is round (a saucer
seen at an angle, a plate), else by the convex closure, and only behind the
occluders (anywhere else the photo would have shown it). Its texture there is
painted by the texture stage (``texture/hidden.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

#: The occluded object's convex closure must take in this fraction of the occluder's visible pixels.
MIN_HIDDEN_FRACTION = 0.02
#: ... and at least this many times the fraction of its own pixels the occluder's closure takes in.
ORDER_RATIO = 3.0
#: An ellipse completes an outline when it holds this fraction of the visible pixels and the visible
#: pixels fill this fraction of it outside the occluders.
ELLIPSE_HOLDS = 0.97
ELLIPSE_FILLS = 0.9


@dataclass
class Completion:
    """One object's completion: its amodal mask (H, W) bool, the objects hiding it, and how it was closed."""

    amodal: np.ndarray
    occluders: list[int] = field(default_factory=list)
    how: str = "whole"  # 'whole' (nothing hides it) | 'ellipse' | 'convex'

    def hidden_pixels(self, visible: np.ndarray) -> int:
        return int((self.amodal & ~visible).sum())


def hull_points(mask: np.ndarray) -> np.ndarray | None:
    """(N, 1, 2) int32 points whose convex hull is that of the pixels of ``mask`` (H, W), None for an empty mask:
    the corners of its outer contours, which hold every extreme pixel. A megapixel mask's own pixels made
    cv2.convexHull take 0.12 s each time, its contours' corners 2 ms, for the same hull."""
    contours, _ = cv2.findContours(np.asarray(mask, np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    return np.concatenate(contours) if contours else None


def _hull(mask: np.ndarray) -> np.ndarray:
    """The filled convex hull (H, W) bool of ``mask``."""
    pts = hull_points(mask > 0)
    out = np.zeros(mask.shape, np.uint8)
    if pts is not None:
        cv2.fillConvexPoly(out, cv2.convexHull(pts), 1)
    return out > 0


def _touch(a: np.ndarray, b: np.ndarray, reach: int) -> bool:
    grown = cv2.dilate(a.astype(np.uint8), np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)) > 0
    return bool((grown & b).any())


def occlusion_order(masks: list[np.ndarray]) -> list[tuple[int, int]]:
    """``(occluder, occluded)`` index pairs of the (H, W) bool visible masks that hide one another."""
    if not masks:
        return []
    reach = max(2, int(round(0.01 * masks[0].shape[0])))
    # a closure's rasterised edge takes in the row of a neighbour's pixels along their shared outline, whoever is
    # in front: a few pixels, and of a sliver (an apple seen only between the fruit in front of it) a few
    # hundredths, which read as the round fruit in front hiding nothing and the sliver hiding them. Which one's
    # closure reaches into the other is judged without that row
    rim = np.ones((3, 3), np.uint8)
    hulls = [_hull(m) for m in masks]
    inner = [h & ~(cv2.dilate(m.astype(np.uint8), rim) > 0) for h, m in zip(hulls, masks)]
    areas = [max(int(m.sum()), 1) for m in masks]
    out = []
    for i in range(len(masks)):
        for j in range(i + 1, len(masks)):
            if not _touch(masks[i], masks[j], reach):
                continue
            into_j = (hulls[i] & masks[j]).sum() / areas[j]  # how much of j lies inside i's closure
            into_i = (hulls[j] & masks[i]).sum() / areas[i]
            deep_j = (inner[i] & masks[j]).sum() / areas[j]  # ... beyond the row along their shared outline
            deep_i = (inner[j] & masks[i]).sum() / areas[i]
            if deep_j + deep_i == 0:
                # a thin occluder (a stick of a pixel or two across a box) lies wholly within that row of the
                # other's outline: nothing is left beyond it, and the raw reach decides as it did before
                deep_j, deep_i = into_j, into_i
            if into_j >= MIN_HIDDEN_FRACTION and deep_j > 0 and deep_j >= ORDER_RATIO * deep_i:
                out.append((j, i))
            elif into_i >= MIN_HIDDEN_FRACTION and deep_i > 0 and deep_i >= ORDER_RATIO * deep_j:
                out.append((i, j))
    return out


def complete(masks: list[np.ndarray], order: list[tuple[int, int]] | None = None) -> list[Completion]:
    """Each visible mask completed behind its occluders (``order`` from :func:`occlusion_order` if not given)."""
    order = occlusion_order(masks) if order is None else order
    out = []
    for k, m in enumerate(masks):
        occluders = sorted({a for a, b in order if b == k})
        if not occluders:
            out.append(Completion(m.copy()))
            continue
        behind = np.any([masks[a] for a in occluders], axis=0) & ~m
        ellipse = _ellipse(m, behind)
        closure, how = (ellipse, "ellipse") if ellipse is not None else (_hull(m), "convex")
        out.append(Completion(m | (closure & behind), occluders, how))
    return out


def _ellipse(visible: np.ndarray, behind: np.ndarray) -> np.ndarray | None:
    """The filled ellipse (H, W) bool through the visible outline away from the occluders, if it fits."""
    contours, _ = cv2.findContours(visible.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return None
    pts = max(contours, key=len)[:, 0]
    near = cv2.dilate(behind.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    free = pts[~near[pts[:, 1], pts[:, 0]]]  # outline the photo shows, not the cut
    if len(free) < 10:
        return None
    box = cv2.fitEllipse(free.astype(np.float32))
    if not all(np.isfinite(box[1])) or min(box[1]) < 2:
        return None
    filled = np.zeros(visible.shape, np.uint8)
    cv2.ellipse(filled, box, 1, -1)
    filled = filled > 0
    holds = (filled & visible).sum() / max(visible.sum(), 1)
    seen = filled & ~behind
    fills = (seen & visible).sum() / max(seen.sum(), 1)
    return filled if holds >= ELLIPSE_HOLDS and fills >= ELLIPSE_FILLS else None

