"""``rerender``: the shot's rendered frames through a video model, the photo as reference, into a new video.

The frames come from the built-in renderer; the objects' pixels of each frame
come from its ray hit buffer (a pixel whose primary ray hits an object). Those
are the masks given to the re-renderer; there is no separate objectId pass.
"""

from __future__ import annotations

import pathlib
import time

import cv2
import numpy as np

from .._files import atomic_path
from ..errors import InputError
from ..report import update_report
from ..usd import layers
from . import registry


def rendered_frames(stage, max_size: int, progress=None) -> tuple[np.ndarray, np.ndarray, float]:
    """Every frame of the composed stage (T, H, W, 3) uint8, its object masks (T, H, W) bool, and the fps."""
    from ..render.video import ShotRenderer
    from ..settings import RenderSettings

    renderer = ShotRenderer(stage, RenderSettings(max_size=max_size))
    start, end = int(stage.GetStartTimeCode()), int(stage.GetEndTimeCode())
    frames, masks = [], []
    for k, t in enumerate(range(start, end + 1)):
        frames.append(renderer.frame(float(t)))
        if renderer.caster is not None:
            masks.append(renderer.caster.depth < 1e5)  # depth is the far limit (1e6) where no object was hit
        else:
            masks.append(np.zeros(frames[-1].shape[:2], bool))
        if progress:
            progress(k + 1, end - start + 1)
    fps = stage.GetFramesPerSecond() or stage.GetTimeCodesPerSecond() or 30.0
    return np.stack(frames), np.stack(masks), float(fps)


def default_prompt(stage) -> str:
    """A plain description from the objects' labels, e.g. 'a cup and a box on the ground, photorealistic'."""
    from ..materials.report import object_prims

    labels = [p.GetAttribute("physomni:label").Get() or p.GetName() for p in object_prims(stage)]
    things = " and ".join(f"a {label}" for label in labels) or "a scene"
    return f"{things} on the ground, photorealistic, consistent lighting"


def rerender_shot(shot, model: str, strength: float = 0.6, steps: int = 20, output=None, prompt: str | None = None,
                  seed: int = 0, max_size: int = 832, progress=None) -> dict:
    """Re-render ``shot`` with re-renderer ``model``; writes the video (default ``rerender.mp4``) and the report."""
    import imageio.v2 as imageio

    from ..render.video import _even

    if not 0.0 < strength <= 1.0:
        raise InputError(f"--strength {strength:g}: must be in (0, 1]")
    if steps < 1:
        raise InputError(f"--steps {steps}: must be at least 1")
    folder = layers.shot_folder(shot)
    out = pathlib.Path(output) if output else folder / "rerender.mp4"
    if out.suffix.lower() != ".mp4" or out.is_dir():
        raise InputError(f"rerender output {out.name} must be an .mp4 file")
    backend = registry.load("rerenderer", model)
    photo_path = folder / "inputs" / "photo.png"
    photo = cv2.imread(str(photo_path), cv2.IMREAD_COLOR)
    if photo is None:
        raise InputError(f"{photo_path} is missing; the shot was built by an older version: run build again")
    t0 = time.perf_counter()
    stage = layers.open_shot(folder)
    frames, masks, fps = rendered_frames(stage, max_size, progress)
    t_render = time.perf_counter()
    new = np.asarray(backend.rerender(frames, masks, cv2.cvtColor(photo, cv2.COLOR_BGR2RGB),
                                      prompt=prompt or default_prompt(stage), strength=strength, steps=steps,
                                      seed=seed))
    if new.shape != frames.shape:
        raise InputError(f"re-renderer {model} returned frames of shape {new.shape}, expected {frames.shape}")
    t_model = time.perf_counter()
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as tmp:
        writer = imageio.get_writer(str(tmp), format="FFMPEG", mode="I", fps=fps, codec="libx264", quality=8,
                                    macro_block_size=1, pixelformat="yuv420p", ffmpeg_log_level="error")
        try:
            for f in new:
                writer.append_data(_even(np.clip(f, 0, 255).astype(np.uint8)))
        finally:
            writer.close()
    section = {"video": str(out), "frames": int(len(new)), "width": int(frames.shape[2]),
               "height": int(frames.shape[1]), "fps": fps, "backend": registry.describe(backend),
               "strength": strength, "steps": steps, "seed": seed, "prompt": prompt or default_prompt(stage),
               "masks": "object hits of the renderer's primary rays",
               "seconds": {"render": round(t_render - t0, 3), "model": round(t_model - t_render, 3),
                           "write": round(time.perf_counter() - t_model, 3)}}
    update_report(folder, rerender=section)
    return section
