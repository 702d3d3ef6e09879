"""Render-and-compare: the photo is the arbiter of the camera the cues propose.

Owns the silhouette comparison of a lifted scene against the photo's masks and the pitch search built on it.
:func:`silhouette` rasterises a triangle mesh through a :class:`~physomni_usd.geometry.camera.PinholeCamera`
with OpenCV (CPU, a few milliseconds at a photo's working size); :func:`mask_iou` compares two masks.
:func:`score_scene` judges one lifted scene: the mismatch between each mesh's silhouette and its (completed)
mask, plus the terms a photo's silhouettes cannot settle alone — support (an object standing on another still
over it), size priors (each label's typical size against the one scale of the scene), and thickness (a
solid object no thinner than a third of its outline's smaller side). :func:`search_pitch` scores the cues'
pitch against a coarse grid of pitches, refined about the best, and keeps the cues' one unless another
explains the whole scene clearly better, so a single cue contradicting every silhouette (a traced board read
as a horizon) loses; a light reading loses too where the silhouettes prefer a far shallower pitch.
:func:`search_row` weighs the fields of view along the curve one vanishing row fixes, where nothing else
reads the field of view.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..geometry.camera import PinholeCamera

#: Sub-pixel bits of the rasteriser's vertex coordinates (cv2.fillPoly's ``shift``).
SHIFT = 4
#: Rasterised at this many times the camera's size, then averaged down (OpenCV fills the pixels edges touch).
SUPERSAMPLE = 4
#: What is nearer the camera than this (its units) is not drawn.
NEAR = 1e-4
#: Triangles are clipped to the frame widened by this fraction of its size each way (the rest is off-screen).
FRAME_MARGIN = 0.5
#: Weights of the score's terms: silhouettes (1 − IoU, mean over objects), size priors (mean squared log of
#: each object's size over its label's after the scene's one scale), thickness (mean shortfall of the thinnest
#: side under a third of the outline's smaller side), support (share of the supports the photo shows that the
#: lift could not keep). Support weighs half what it did (0.3): whether a lift keeps a support is a yes or no
#: that flips from one pitch to the next (a fruit whose foot a bowl's rim hides balances on the bowl from 45
#: degrees and not from 10), and at 0.3 one flip outweighed every silhouette (a scene seen from 11 degrees
#: read at 75; bench general seed 775672).
WEIGHTS = {"silhouette": 1.0, "size": 0.5, "thin": 0.5, "support": 0.15}
#: Coarse grid of pitches tried (degrees), then a finer step about the best. At 15 the grid stepped over
#: valleys narrower than a step (a view from 27 degrees read at 12).
COARSE_STEP_DEG = 10.0
FINE_STEP_DEG = 5.0
#: Another pitch replaces the cues' one only when its score is lower by at least this much (absolute) plus
#: this fraction of the cues' score: the cues' reading is kept where the silhouettes cannot tell.
MIN_GAIN = 0.02
MIN_GAIN_FRACTION = 0.4
#: ... or this fraction when a strong cue (a vanishing point, an ellipse) reads the cues' pitch.
STRONG_GAIN_FRACTION = 0.7
#: Pitches scoring within this fraction (plus NEAR_BEST_ABS) of the best are as good as the best.
NEAR_BEST_FRACTION = 0.15
NEAR_BEST_ABS = 0.01
#: Fields of view (degrees, vertical) the view search (:func:`search_view`) grids, and its first step in them.
FOV_GRID_DEG = (30.0, 40.0, 50.0, 60.0, 70.0)
FOV_FINE_STEP_DEG = 5.0
#: A field of view along a vanishing row replaces the default one when it beats it by MIN_GAIN plus this
#: fraction of its score: half what a pitch needs, the default being no reading of the photo.
ROW_GAIN_FRACTION = 0.2
#: Fields of view (degrees, vertical) tried along a vanishing row (:func:`search_row`).
ROW_FOVS_DEG = (25.0, 30.0, 35.0, 40.0, 45.0, 50.0, 55.0, 60.0, 65.0, 70.0, 75.0, 80.0)
#: Silhouette IoU under which ``build`` warns, naming the object.
WARN_IOU = 0.85
#: Largest log-ratio one object adds to the size term (a failed lift counts, but does not swamp the rest).
SIZE_LOG_CAP = math.log(4.0)
#: What a side the photo did not give adds to the size term (see :func:`prior_terms`): the log of the priors'
#: spread, as a side read and agreeing with its label only as well as labels do.
UNREAD_LOG = math.log(1.5)


def silhouette(vertices: np.ndarray, faces: np.ndarray, camera: PinholeCamera) -> np.ndarray:
    """(H, W) bool: the pixels the mesh (``vertices`` (N, 3) world, ``faces`` (M, 3)) covers through
    ``camera``; what is behind the camera is cut away."""
    h, w = camera.height, camera.width
    if len(faces) == 0:
        return np.zeros((h, w), bool)
    k = SUPERSAMPLE
    out = np.zeros((h * k, w * k), np.uint8)
    p = (np.asarray(vertices, float) - camera.origin) @ camera.world_from_camera  # camera axes (N, 3)
    tri = np.asarray(faces, np.int64)
    planes = _frustum(camera)
    inside = np.all(p[tri] @ planes[:, :3].T + planes[:, 3] >= 0.0, axis=(1, 2))
    # triangles wholly inside a frustum a margin wider than the frame project as they are; the others (a
    # floor reaching behind the camera) are clipped to it first, so every corner projects finitely
    f = camera.focal_px
    centre = np.array(camera.principal_point)

    def to_fixed(q):  # (..., 3) camera axes → fixed-point pixels of the k× grid, pixel centres at integer + 0.5
        uv = q[..., :2] / q[..., 2:3] * f + centre
        return np.round((uv * k - 0.5) * (1 << SHIFT)).astype(np.int32)

    fixed = list(to_fixed(p[tri[inside]]))
    for t in tri[~inside]:
        clipped = _clip(p[t], planes)
        if len(clipped) >= 3:
            fixed.append(to_fixed(clipped))
    # one triangle at a time: fillPoly given them all fills by parity, and overlapping triangles cancel
    for t in fixed:
        cv2.fillConvexPoly(out, t, 255, lineType=cv2.LINE_8, shift=SHIFT)
    # OpenCV fills every pixel a triangle's edge touches: at k× and then by area, a pixel is in where its
    # centre half is, as a ray cast through pixel centres has it
    return cv2.resize(out, (w, h), interpolation=cv2.INTER_AREA) >= 128


def _frustum(camera: PinholeCamera) -> np.ndarray:
    """(5, 4) planes (normal, offset) in camera axes whose positive sides bound what is drawn: in front of
    :data:`NEAR`, and within the frame widened by :data:`FRAME_MARGIN` of its size each way."""
    f = camera.focal_px
    cx, cy = camera.principal_point
    mu, mv = FRAME_MARGIN * camera.width, FRAME_MARGIN * camera.height
    lo_u, hi_u, lo_v, hi_v = -mu, camera.width + mu, -mv, camera.height + mv
    return np.array([[0.0, 0.0, 1.0, -NEAR],
                     [f, 0.0, cx - lo_u, 0.0], [-f, 0.0, hi_u - cx, 0.0],  # u ≥ lo_u, u ≤ hi_u
                     [0.0, f, cy - lo_v, 0.0], [0.0, -f, hi_v - cy, 0.0]])


def _clip(poly: np.ndarray, planes: np.ndarray) -> np.ndarray:
    """The convex polygon ``poly`` (n, 3) cut to the positive side of every plane (Sutherland–Hodgman)."""
    for plane in planes:
        if len(poly) == 0:
            break
        d = poly @ plane[:3] + plane[3]
        out = []
        for i in range(len(poly)):
            j = (i + 1) % len(poly)
            if d[i] >= 0:
                out.append(poly[i])
            if (d[i] >= 0) != (d[j] >= 0):
                out.append(poly[i] + (poly[j] - poly[i]) * (d[i] / (d[i] - d[j])))
        poly = np.array(out).reshape(-1, 3)
    return poly


def mask_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two (H, W) masks; 1 when both are empty."""
    a, b = np.asarray(a, bool), np.asarray(b, bool)
    union = int((a | b).sum())
    return 1.0 if union == 0 else float((a & b).sum()) / union


def silhouette_ious(vertex_sets, faces, camera: PinholeCamera, masks) -> list[float]:
    """Per object, the IoU of its mesh's whole silhouette through ``camera`` with its mask (same size)."""
    return [mask_iou(silhouette(v, f, camera), m) for v, f, m in zip(vertex_sets, faces, masks)]


def visible_ious(vertex_sets, faces, camera: PinholeCamera, masks) -> list[float]:
    """Per object, the IoU of what the shot shows of it through ``camera`` with what the photo shows of it
    (``masks``, its visible masks at the camera's size): its mesh cut out by its mask, as its texture's alpha
    cuts it, and hidden only where a nearer mesh is opaque (``geometry.raycast.cut_out_silhouettes``). The bare
    meshes span their outlines' concavities, which the textures cut away: against them a motorcycle scores
    its filled wheel gap and hides the bench behind that gap."""
    from ..geometry.raycast import cut_out_silhouettes

    seen = cut_out_silhouettes(list(vertex_sets), list(faces), camera, list(masks))
    return [mask_iou(s, m) for s, m in zip(seen, masks)]


def prior_terms(vertex_sets, labels, scale: float = 1.0, heights_read=None) -> tuple[list[float], list[float]]:
    """The size-prior and thickness terms of :func:`score_scene` for meshes ``vertex_sets`` (camera units,
    times ``scale`` for metres) labelled ``labels``: per object with a typical size, the log of its longest side
    over its label's and of its height over length over its label's (each at most :data:`SIZE_LOG_CAP`); per
    object, the shortfall (0..1) of its thinnest side under a third of its middle one, unless its label says
    it lies flat.

    ``heights_read`` (per object, default all): whether the lift read the object's height from the photo. A
    height the lift took from the label agrees with it by construction, and seen from above every height is
    the label's: counted, it pulled the pitch search to straight-down views where no cue read the pitch (a pot
    and plant seen from 23 degrees read at 87). Such an object is held to the label by its footprint where the
    label's thing lies longer than it stands tall (a book), the footprint's longest side being then the
    label's; each side it does not show counts :data:`UNREAD_LOG` at every pitch (left out, the views from
    above, with fewer terms, won as well), and it adds no thinness.

    Tried on bench general's fresh seeds 325970 and 426707, sparing the priors' 1.5x spread or the proportions
    of labels that rest any way each made the pitch worse (5 of 8 scenes within 10 degrees fell to 3): the
    squared log's slope near the prior is what tells pitches apart."""
    from ..lift.silhouette import FLAT_PRIOR_RATIO
    from ..sizes import size_prior

    size_logs, thin = [], []
    for k, (v, label) in enumerate(zip(vertex_sets, labels)):
        prior = size_prior(label)
        v = np.asarray(v, float) * scale
        ext = np.sort(principal_extents(v))
        read = heights_read is None or bool(heights_read[k])
        if prior is not None and prior.votes and ext[2] > 0:
            if read:
                longest = abs(math.log(ext[2] / prior.longest_m))
            elif (prior.height_m or 0.0) < prior.longest_m:  # lies long: the footprint's longest is the label's
                longest = abs(math.log(max(principal_extents(np.c_[v[:, :2], np.zeros(len(v))]).max(), 1e-9)
                                       / prior.longest_m))
            else:
                longest = UNREAD_LOG
            size_logs.append(min(longest, SIZE_LOG_CAP))
            if prior.height_m:  # its height over its length, as the label's: free of the scene's scale
                if read:
                    h = float(np.ptp(v[:, 2]))
                    size_logs.append(min(abs(math.log(max(h, 1e-6) / ext[2] / (prior.height_m / prior.longest_m))),
                                         SIZE_LOG_CAP))
                else:
                    size_logs.append(UNREAD_LOG)
        flat = bool(prior and prior.height_m and prior.height_m <= FLAT_PRIOR_RATIO * (prior.longest_m or 0.0))
        # a height copied from the label is no thinness the photo shows (seen from above, a box's footprint
        # wider than its label's height): counted, it held straight-down views back by the label alone
        thin.append(0.0 if flat or not read or ext[1] <= 0 else max(0.0, 1.0 - ext[0] / (ext[1] / 3.0)))
    return size_logs, thin


def principal_extents(vertices: np.ndarray) -> np.ndarray:
    """(3,) extents of ``vertices`` along their principal axes."""
    v = vertices - vertices.mean(0)
    try:
        _, _, axes = np.linalg.svd(v, full_matrices=False)
    except np.linalg.LinAlgError:
        return np.ptp(vertices, axis=0)
    # fewer than three vertices span fewer than three axes; the ones they lack have no extent
    ext = np.ptp(v @ axes.T, axis=0)
    return np.pad(ext, (0, 3 - len(ext)))


@dataclass
class SceneScore:
    """One lifted scene's mismatch with the photo; lower is better."""

    total: float
    terms: dict
    ious: list[float] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {"score": round(self.total, 4), **{k: round(v, 4) for k, v in self.terms.items()},
                "silhouette_iou": [round(x, 4) for x in self.ious]}


def score_scene(vertex_sets, faces, camera: PinholeCamera, masks, size_logs=(), thin=(),
                supports_lost: float = 0.0) -> SceneScore:
    """The score of one lifted scene (see the module): ``masks`` the outlines it was lifted from (H, W);
    ``size_logs`` each object's log(size / its label's typical size) after the scene's scale (objects with no
    typical size left out); ``thin`` each object's shortfall (0..1) of its thinnest side under a third of its
    outline's smaller side; ``supports_lost`` the share of the photo's supports the lift dropped."""
    ious = silhouette_ious(vertex_sets, faces, camera, masks)
    terms = {"silhouette": 1.0 - float(np.mean(ious)) if ious else 0.0,
             "size": float(np.mean(np.square(size_logs))) if len(size_logs) else 0.0,
             "thin": float(np.mean(thin)) if len(thin) else 0.0,
             "support": float(supports_lost)}
    total = sum(WEIGHTS[k] * v for k, v in terms.items())
    return SceneScore(total, terms, ious)


@dataclass
class PitchSearch:
    pitch_deg: float
    cue_pitch_deg: float
    score: SceneScore
    cue_score: SceneScore
    tried: list[tuple[float, float]]  # (pitch°, score), in the order tried

    def as_dict(self) -> dict:
        return {"pitch_deg": round(self.pitch_deg, 3), "cue_pitch_deg": round(self.cue_pitch_deg, 3),
                "chosen": "cues" if self.pitch_deg == self.cue_pitch_deg else "silhouettes",
                "score": self.score.as_dict(), "cue_score": self.cue_score.as_dict(),
                "tried": [[round(p, 2), round(s, 4)] for p, s in self.tried]}


@dataclass
class ViewSearch:
    pitch_deg: float
    fov_deg: float
    cue_pitch_deg: float
    cue_fov_deg: float
    score: SceneScore
    cue_score: SceneScore
    tried: list[tuple[float, float, float]]  # (pitch°, fov°, score), in the order tried

    def as_dict(self) -> dict:
        cues = self.pitch_deg == self.cue_pitch_deg and self.fov_deg == self.cue_fov_deg
        return {"pitch_deg": round(self.pitch_deg, 3), "fov_deg": round(self.fov_deg, 3),
                "cue_pitch_deg": round(self.cue_pitch_deg, 3), "cue_fov_deg": round(self.cue_fov_deg, 3),
                "chosen": "cues" if cues else "silhouettes", "score": self.score.as_dict(),
                "cue_score": self.cue_score.as_dict(),
                "tried": [[round(p, 2), round(f, 2), round(s, 4)] for p, f, s in self.tried]}


def search_view(evaluate, cue_pitch: float, cue_fov: float, lowest, highest: float,
                fovs=FOV_GRID_DEG, coarse_step: float = COARSE_STEP_DEG, fine_step: float = FINE_STEP_DEG,
                fov_step: float = FOV_FINE_STEP_DEG, gain_fraction: float = MIN_GAIN_FRACTION) -> ViewSearch:
    """The pitch and field of view (degrees) whose lifted scene scores best, where no cue reads the field of
    view: the two trade against each other (a wider view pitched more puts the horizon on the same row), so
    they are searched together, not one after the other. ``evaluate(pitch, fov) -> SceneScore | None``;
    ``lowest(fov)`` the least pitch that stands every foot on the ground under ``fov``. A coarse grid (pitches
    ``coarse_step`` apart under each of ``fovs``), then a pattern search about the best (``fine_step`` in
    pitch and ``fov_step`` in field of view, halved twice); the cues' camera stays unless another beats it
    as :func:`search_pitch`'s rule has it, and of those about as good as the best the one nearest the cues'
    (a degree of view counting as one of pitch) is taken."""
    scores: dict[tuple[float, float], SceneScore | None] = {}

    def at(p: float, f: float):
        f = float(min(max(f, fovs[0] - fov_step), fovs[-1] + fov_step))
        p = float(min(max(p, lowest(f)), highest))
        key = (round(p, 3), round(f, 3))
        if key not in scores:
            scores[key] = evaluate(*key)
        return key

    cue_key = at(cue_pitch, cue_fov)
    for f in fovs:
        start = math.ceil(max(lowest(f), 0.0) / coarse_step) * coarse_step
        for p in list(np.arange(start, highest + 1e-9, coarse_step)) + [highest]:
            at(p, f)
    step, fstep = fine_step, fov_step
    for _ in range(3):
        valid = {k: v for k, v in scores.items() if v is not None}
        if not valid:
            break
        bp, bf = min(valid, key=lambda k: valid[k].total)
        for dp, df in ((-step, 0.0), (step, 0.0), (0.0, -fstep), (0.0, fstep)):
            at(bp + dp, bf + df)
        step, fstep = step / 2, fstep / 2
    valid = {k: v for k, v in scores.items() if v is not None}
    if not valid:
        raise ValueError("no camera gave a scene")
    tried = [(p, f, v.total) for (p, f), v in valid.items()]
    best = min(valid, key=lambda k: valid[k].total)
    cue = scores[cue_key]
    if cue is None:
        return ViewSearch(*best, *cue_key, valid[best], valid[best], tried)
    beats = cue.total - MIN_GAIN - gain_fraction * cue.total
    near = [k for k, v in valid.items()
            if v.total <= min(beats, valid[best].total * (1.0 + NEAR_BEST_FRACTION) + NEAR_BEST_ABS)]
    if near:
        pick = min(near, key=lambda k: (abs(k[0] - cue_key[0]) + abs(k[1] - cue_key[1]), valid[k].total))
        return ViewSearch(*pick, *cue_key, valid[pick], cue, tried)
    return ViewSearch(*cue_key, *cue_key, cue, cue, tried)


def search_pitch(evaluate, cue_pitch: float, lowest: float, highest: float,
                 coarse_step: float = COARSE_STEP_DEG, fine_step: float = FINE_STEP_DEG,
                 gain_fraction: float = MIN_GAIN_FRACTION, window_deg: float | None = None,
                 trust_deg: float | None = None, anchor: float | None = None, pick: str = "nearest") -> PitchSearch:
    """The pitch (degrees) whose lifted scene scores best, from ``lowest`` to ``highest``.

    ``evaluate(pitch) -> SceneScore | None`` lifts and scores the scene under that pitch (None: no scene
    there). The cues' ``cue_pitch`` is scored first, then a coarse grid, then ``fine_step`` either side of
    the best twice halving. The cues' pitch stays unless a pitch beats it by :data:`MIN_GAIN` plus
    ``gain_fraction`` of its score; of the pitches that do and score within :data:`NEAR_BEST_FRACTION` (plus
    :data:`NEAR_BEST_ABS`) of the best, the one nearest the cues' is taken.

    ``window_deg``: only pitches that near the cues' are taken (a strong reading is refined, not replaced).
    ``trust_deg``: the whole range is scored all the same, and where its best lies more than ``trust_deg``
    *below* the cues' pitch the reading loses and the best is taken: the silhouettes lean towards steep
    views (from straight above any outline matches), so a shallower view they prefer against that lean
    outweighs a light reading (a tabletop's printed lines read as verticals). ``anchor``: a reading too light
    to move the cues' pitch (a steep horizon nothing confirms), scored too; the near-best pitches are taken
    nearest to it instead of the cues'. ``pick`` "best": of the near-best pitches the best-scoring is taken, not
    the one nearest the cues' (where the cues' pitch is a default, no reading of the photo: taken nearest, a
    score flat from 22 to 35 degrees gave 22, the end nearest the feet's 10)."""
    scores: dict[float, SceneScore | None] = {}
    key_cue = round(float(min(max(cue_pitch, lowest), highest)), 3)
    if window_deg is not None and trust_deg is None:  # nothing outside the window can be taken: not scored
        lowest, highest = max(lowest, key_cue - window_deg), min(highest, key_cue + window_deg)

    def at(p: float):
        p = float(min(max(p, lowest), highest))
        key = round(p, 3)
        if key not in scores:
            scores[key] = evaluate(p)
        return scores[key]

    def inside(k: float) -> bool:
        return window_deg is None or abs(k - key_cue) <= window_deg + 1e-9

    cue = at(cue_pitch)
    key_anchor = None
    if anchor is not None:
        key_anchor = round(float(min(max(anchor, lowest), highest)), 3)
        at(anchor)
    start = math.ceil(lowest / coarse_step) * coarse_step
    for p in np.arange(start, highest + 1e-9, coarse_step):
        at(p)
    if highest - start < 1e-9 or highest - (start + coarse_step * int((highest - start) / coarse_step)) > 1.0:
        at(highest)
    step = fine_step
    for _ in range(2):
        valid = [k for k, s in scores.items() if s is not None]
        # refined about the best of the whole range and about the best the window allows
        bests = {min(ks, key=lambda k: scores[k].total) for ks in (valid, [k for k in valid if inside(k)]) if ks}
        for best in sorted(bests):
            at(best - step)
            at(best + step)
        step /= 2
    valid = {k: s for k, s in scores.items() if s is not None}
    tried = [(k, s.total) for k, s in valid.items()]
    if cue is None:
        if not valid:
            raise ValueError("no pitch gave a scene")
        best = min(valid, key=lambda k: valid[k].total)
        return PitchSearch(best, key_cue, valid[best], valid[best], tried)
    overall = min(valid, key=lambda k: valid[k].total)
    if trust_deg is not None and key_cue - overall > trust_deg:
        return PitchSearch(overall, key_cue, valid[overall], cue, tried)
    valid = {k: v for k, v in valid.items() if inside(k)}
    best = min(valid, key=lambda k: valid[k].total)
    beats = cue.total - MIN_GAIN - gain_fraction * cue.total
    centre = key_anchor if key_anchor is not None and inside(key_anchor) else key_cue
    # where the scores are flat near the best (seen from above, any outline matches), the pitch nearest the
    # cues' among those about as good: the silhouettes move the cues' reading only as far as they need to
    near = [k for k, v in valid.items()
            if v.total <= min(beats, valid[best].total * (1.0 + NEAR_BEST_FRACTION) + NEAR_BEST_ABS)]
    if near:
        if pick == "best":
            chosen = min(near, key=lambda k: valid[k].total)
        else:
            chosen = min(near, key=lambda k: (abs(k - centre), valid[k].total))
        return PitchSearch(chosen, key_cue, valid[chosen], cue, tried)
    return PitchSearch(key_cue, key_cue, cue, cue, tried)


def search_row(evaluate, pitch_of, cue_fov: float, lowest, fovs=ROW_FOVS_DEG,
               gain_fraction: float = ROW_GAIN_FRACTION) -> ViewSearch:
    """The field of view (and the pitch it gives) along the curve a vanishing row fixes, where that row reads
    the pitch and nothing reads the field of view: ``pitch_of(fov)`` the pitch the row means under ``fov``,
    ``lowest(fov)`` the least that stands every foot on the ground (a field of view under which the row puts
    a foot above the horizon is no camera of the photo). ``evaluate(pitch, fov) -> SceneScore | None``. The
    cues' field of view stays unless another beats it as :func:`search_pitch`'s rule has it; of those about
    as good as the best, the one nearest the cues' is taken."""
    scored: dict[float, tuple[float, SceneScore | None]] = {}
    for f in sorted({float(cue_fov), *map(float, fovs)}):
        p = pitch_of(f)
        if p is None or p < lowest(f) or p > 90.0:
            continue
        scored[round(f, 3)] = (round(float(p), 3), evaluate(round(float(p), 3), round(f, 3)))
    valid = {f: (p, v) for f, (p, v) in scored.items() if v is not None}
    tried = [(p, f, v.total) for f, (p, v) in valid.items()]
    if not valid:
        raise ValueError("no field of view gave a scene along the row")
    best = min(valid, key=lambda f: valid[f][1].total)
    key_cue = round(float(cue_fov), 3)
    if key_cue not in valid:  # the cues' own camera puts a foot above its horizon: the row's best stands
        p = pitch_of(cue_fov)
        return ViewSearch(valid[best][0], best, valid[best][0] if p is None else round(float(p), 3), key_cue,
                          valid[best][1], valid[best][1], tried)
    cue_p, cue = valid[key_cue]
    beats = cue.total - MIN_GAIN - gain_fraction * cue.total
    near = [f for f, (_, v) in valid.items()
            if v.total <= min(beats, valid[best][1].total * (1.0 + NEAR_BEST_FRACTION) + NEAR_BEST_ABS)]
    pick = min(near, key=lambda f: (abs(f - key_cue), valid[f][1].total)) if near else key_cue
    return ViewSearch(valid[pick][0], pick, cue_p, key_cue, valid[pick][1], cue, tried)
