"""``rerender``: the shot's rendered frames through a video model, the photo as reference, into a new video.

The frames come from the built-in renderer, and with them the exact control
passes of ``render --passes`` (depth along the optical axis, object ids, forward
motion), computed in memory from the same rays. The masks given to the
re-renderer are the objects' pixels (``objectId > 0``); a re-renderer whose
``rerender`` takes a ``passes`` keyword also gets the passes themselves.
"""

from __future__ import annotations

import inspect
import pathlib
import time

import numpy as np

from ._files import atomic_path
from .errors import InputError
from .limits import Limit, Limits
from .report import update_report
from .swappable import registry
from .swappable.protocols import ControlPasses
from .usd import layers


def rendered_frames(stage, max_size: int, progress=None) -> tuple[np.ndarray, ControlPasses, float]:
    """Every frame of the composed stage (T, H, W, 3) uint8, their control passes, and the fps."""
    from .rendering.passes import frame_passes
    from .rendering.video import ShotRenderer
    from .settings import RenderSettings

    renderer = ShotRenderer(stage, RenderSettings(max_size=max_size))
    start, end = int(stage.GetStartTimeCode()), int(stage.GetEndTimeCode())
    frames, depth, ids, motion = [], [], [], []
    cache: dict = {}
    for k, t in enumerate(range(start, end + 1)):
        image, state = renderer.render(float(t))
        frames.append(image)
        p = frame_passes(renderer, state, float(t + 1) if t < end else None, cache)
        depth.append(p["Z"])
        ids.append(p["objectId"])
        motion.append(p["motion"])
        if progress:
            progress(k + 1, end - start + 1)
    fps = stage.GetFramesPerSecond() or stage.GetTimeCodesPerSecond() or 30.0
    return np.stack(frames), ControlPasses(np.stack(depth), np.stack(ids), np.stack(motion)), float(fps)


def takes_passes(backend) -> bool:
    """Whether ``backend.rerender`` accepts the ``passes`` keyword (re-renderers written before it do not)."""
    try:
        params = inspect.signature(backend.rerender).parameters
    except (TypeError, ValueError):
        return False
    return "passes" in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


def default_model() -> str:
    """The one installed re-renderer; otherwise one line saying what to install or to choose with --model."""
    names = [e.name for e in registry.entries() if e.kind == "rerenderer"]
    if len(names) == 1:
        return names[0]
    if names:
        raise InputError(f"--model: several re-renderers are installed ({', '.join(names)}); choose one")
    hint = registry.SUGGESTED["rerenderer"]
    raise InputError(f"no re-renderer is installed: install the {hint} plugin (pip install -e plugins/{hint}) "
                     "and name it with --model")


def default_prompt(stage) -> str:
    """A plain description from the objects' labels, e.g. 'a cup and a box on the ground, photorealistic'."""
    from .usd.contract import object_prims

    labels = [p.GetAttribute("physomni:label").Get() or p.GetName() for p in object_prims(stage)]
    things = " and ".join(f"a {label}" for label in labels) or "a scene"
    return f"{things} on the ground, photorealistic, consistent lighting"


#: The re-render's numbers (``rerender_shot``'s arguments), with their options, defaults and ranges.
LIMITS = Limits(
    strength=Limit("--strength", "Share of the denoising run: low keeps the rendered frames, 1 starts from noise.",
                   0, 1, 0.6, lo_open=True),
    steps=Limit("--steps", "Denoising steps actually run.", 1, 1000, 20, whole=True),
    seed=Limit("--seed", "Random seed of the noise.", None, None, 0, whole=True),
    max_size=Limit("--max-size", "Longest side of the frames given to the model, pixels.", 16, 8192, 832, whole=True),
)


def rerender_shot(shot, model: str | None, strength: float = 0.6, steps: int = 20, output=None, prompt: str | None = None,
                  seed: int = 0, max_size: int = 832, progress=None) -> dict:
    """Re-render ``shot`` with re-renderer ``model`` (None: the one installed); writes the video (default
    ``rerender.mp4``) and the report."""
    import cv2  # here, not at the top: the command line reads this module's LIMITS at start-up

    from .rendering.encode import even_sides, video_writer

    LIMITS.check(strength=strength, steps=steps, seed=seed, max_size=max_size)
    folder = layers.shot_folder(shot)
    out = pathlib.Path(output) if output else folder / "rerender.mp4"
    if out.suffix.lower() != ".mp4" or out.is_dir():
        raise InputError(f"rerender output {out.name} must be an .mp4 file")
    model = model or default_model()
    backend = registry.load("rerenderer", model)
    photo_path = folder / "inputs" / "photo.png"
    photo = cv2.imread(str(photo_path), cv2.IMREAD_COLOR)
    if photo is None:
        raise InputError(f"{photo_path} is missing or unreadable: the re-renderer is given the photo, which `build` "
                         "keeps there")
    t0 = time.perf_counter()
    stage = layers.open_shot(folder)
    frames, passes, fps = rendered_frames(stage, max_size, progress)
    masks = passes.object_id > 0
    t_render = time.perf_counter()
    extra = {"passes": passes} if takes_passes(backend) else {}
    new = np.asarray(backend.rerender(frames, masks, cv2.cvtColor(photo, cv2.COLOR_BGR2RGB),
                                      prompt=prompt or default_prompt(stage), strength=strength, steps=steps,
                                      seed=seed, **extra))
    if new.shape != frames.shape:
        raise InputError(f"re-renderer {model} returned frames of shape {new.shape}, expected {frames.shape}")
    t_model = time.perf_counter()
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as tmp:
        writer = video_writer(tmp, fps, 8)
        try:
            for f in new:
                writer.append_data(even_sides(np.clip(f, 0, 255).astype(np.uint8)))
        finally:
            writer.close()
    section = {"video": str(out), "frames": int(len(new)), "width": int(frames.shape[2]),
               "height": int(frames.shape[1]), "fps": fps, "model": model, "backend": registry.describe(backend),
               "strength": strength, "steps": steps, "seed": seed, "prompt": prompt or default_prompt(stage),
               "masks": "objectId > 0 of the control passes",
               "passes": ["depth", "objectId", "motion"] if extra else [],
               "seconds": {"render": round(t_render - t0, 3), "model": round(t_model - t_render, 3),
                           "write": round(time.perf_counter() - t_model, 3)}}
    update_report(folder, rerender=section)
    return section
