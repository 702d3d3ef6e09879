"""Wan VACE re-rendering for physomni-usd, through ``diffusers``' ``WanVACEPipeline``.

Registered as the ``wan-vace`` re-renderer. Weights: a diffusers pipeline
folder (``model_index.json``; Wan 2.1 VACE, or Wan 2.2 with ``transformer_2``
and ``boundary_ratio``, which the pipeline reads itself) named by
``PHYSOMNI_WAN_WEIGHTS``.

The control ``video`` is the rendered frames, except on the objects' pixels
(``objectId > 0`` of the control passes, grown by a few pixels), where it is
their depth pass drawn as VACE's depth maps are (near bright, far dark); those
pixels are also the ``mask``, so the model keeps the rendered world and repaints
the objects following their exact depth. The photo is the reference image.
Without passes (an older caller) the frames are the control video and the
masks the mask. Wan VACE has no motion input: the flow pass is not used. Partial denoising: the frames are
encoded by the VAE, noised to the level ``strength`` of the flow-matching
schedule and denoised from there over ``steps`` steps. Text embeddings are
computed once per prompt with the pipeline's own text encoder and cached
(``PHYSOMNI_WAN_CACHE``, default ``~/.cache/physomni-usd/wan``); a cached prompt
needs neither the tokenizer nor the text encoder. Importing this module
imports no torch.
"""

from __future__ import annotations

import hashlib
import math
import os
import pathlib

import numpy as np

from physomni_usd.swappable import registry

ENV = "PHYSOMNI_WAN_WEIGHTS"
ENV_CACHE = "PHYSOMNI_WAN_CACHE"
WHAT = "a diffusers WanVACEPipeline folder (e.g. Wan-AI/Wan2.1-VACE-1.3B-diffusers)"
NEGATIVE = "blurry, distorted, low quality, flicker, watermark, text"
__version__ = "0.1.0"


def cache_dir() -> pathlib.Path:
    return pathlib.Path(os.environ.get(ENV_CACHE) or pathlib.Path.home() / ".cache" / "physomni-usd" / "wan")


def embeddings_file(weights: str, prompt: str) -> pathlib.Path:
    """Where the embeddings of ``prompt`` (and of the negative prompt) for these weights are cached."""
    key = hashlib.sha256(f"{pathlib.Path(weights).resolve()}\n{prompt}\n{NEGATIVE}".encode()).hexdigest()[:24]
    return cache_dir() / f"{key}.pt"


class WanVACE:
    """Re-renders frames with Wan VACE."""

    kind, name = "rerenderer", "wan-vace"

    @classmethod
    def weights(cls) -> str | None:
        return os.environ.get(ENV) or None

    @classmethod
    def missing(cls) -> str | None:
        return (registry.lacking_modules(("torch", "diffusers", "transformers"), "the wan-vace re-renderer",
                                         "physomni-wan[models]")
                or registry.weights_problem(ENV, WHAT, "model_index.json"))

    def __init__(self):
        import torch

        self.path = self.weights()
        self.device = "cuda" if torch.cuda.is_available() else "cpu"
        self.dtype = torch.bfloat16 if self.device == "cuda" else torch.float32

    def _embeddings(self, prompt: str):
        """(prompt_embeds, negative_prompt_embeds), from the cache or computed once and cached."""
        import torch

        path = embeddings_file(self.path, prompt)
        if path.is_file():
            cached = torch.load(path, map_location="cpu", weights_only=True)
            return cached["prompt"], cached["negative"]
        import json

        from diffusers import WanVACEPipeline

        from physomni_usd._files import write_bytes
        from physomni_usd.errors import InputError

        index = json.loads((pathlib.Path(self.path) / "model_index.json").read_text())
        if not all((index.get(k) or [None])[0] for k in ("text_encoder", "tokenizer")):
            raise InputError(f"{ENV}={self.path} has no text encoder or tokenizer to embed the prompt, and "
                             f"{path} (its cached embeddings) does not exist")
        pipe = WanVACEPipeline.from_pretrained(self.path, torch_dtype=self.dtype)
        pipe.to(self.device)
        with torch.inference_mode():
            pos, neg = pipe.encode_prompt(prompt, NEGATIVE, do_classifier_free_guidance=True, device=self.device)
        import io

        buf = io.BytesIO()
        torch.save({"prompt": pos.cpu(), "negative": neg.cpu()}, buf)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes(path, buf.getvalue())
        return pos.cpu(), neg.cpu()

    def rerender(self, frames: np.ndarray, masks, reference: np.ndarray, *, prompt: str, strength: float,
                 steps: int, seed: int, passes=None) -> np.ndarray:
        """(T, H, W, 3) uint8 frames re-rendered; sizes are rounded to the model's grid and restored."""
        import cv2
        import torch
        from diffusers import WanVACEPipeline
        from PIL import Image

        pos, neg = self._embeddings(prompt)
        pipe = WanVACEPipeline.from_pretrained(self.path, tokenizer=None, text_encoder=None, torch_dtype=self.dtype)
        pipe.to(self.device)
        pipe.set_progress_bar_config(disable=True)
        t, h, w = frames.shape[:3]
        transformer = pipe.transformer if pipe.transformer is not None else pipe.transformer_2
        grid = pipe.vae_scale_factor_spatial * transformer.config.patch_size[1]
        gh, gw = max(grid, round(h / grid) * grid), max(grid, round(w / grid) * grid)
        step_t = pipe.vae_scale_factor_temporal
        n = ((t - 1 + step_t - 1) // step_t) * step_t + 1  # Wan wants 4k + 1 frames: repeat the last ones
        index = np.minimum(np.arange(n), t - 1)
        rendered = [Image.fromarray(cv2.resize(frames[i], (gw, gh), interpolation=cv2.INTER_AREA)) for i in index]
        video = rendered
        if passes is not None:
            masks, control = depth_control(frames, passes.depth, passes.object_id)
            video = [Image.fromarray(cv2.resize(control[i], (gw, gh), interpolation=cv2.INTER_AREA)) for i in index]
        if masks is None:
            mask = [Image.new("L", (gw, gh), 255)] * n
        else:
            mask = [Image.fromarray(cv2.resize(masks[i].astype(np.uint8) * 255, (gw, gh),
                                               interpolation=cv2.INTER_NEAREST)) for i in index]
        ref = Image.fromarray(cv2.resize(reference, (gw, gh), interpolation=cv2.INTER_AREA))
        generator = torch.Generator(device="cpu").manual_seed(seed)
        latents = self._start_latents(pipe, rendered, ref, gh, gw, strength, steps, generator)
        _truncate_schedule(pipe.scheduler, steps, strength)
        with torch.inference_mode():
            out = pipe(video=video, mask=mask, reference_images=[ref], prompt_embeds=pos.to(self.device, self.dtype),
                       negative_prompt_embeds=neg.to(self.device, self.dtype), height=gh, width=gw, num_frames=n,
                       num_inference_steps=_total_steps(steps, strength), guidance_scale=5.0,
                       generator=generator, latents=latents, output_type="np").frames[0]
        out = np.clip(np.asarray(out[:t]) * 255.0 + 0.5, 0, 255).astype(np.uint8)
        return np.stack([cv2.resize(f, (w, h), interpolation=cv2.INTER_CUBIC) for f in out])

    def _start_latents(self, pipe, video, ref, gh, gw, strength, steps, generator):
        """The rendered frames (after the reference frame) encoded and noised to the schedule's first level."""
        import torch
        from diffusers.pipelines.wan.pipeline_wan_vace import retrieve_latents

        vae = pipe.vae
        frames = pipe.video_processor.preprocess_video(video, gh, gw).to(self.device, vae.dtype)
        refs = pipe.video_processor.preprocess(ref, gh, gw).to(self.device, vae.dtype)[:, :, None]
        mean = torch.tensor(vae.config.latents_mean, device=self.device).view(1, -1, 1, 1, 1)
        inv_std = 1.0 / torch.tensor(vae.config.latents_std, device=self.device).view(1, -1, 1, 1, 1)
        with torch.inference_mode():
            x0 = torch.cat([retrieve_latents(vae.encode(refs), sample_mode="argmax"),
                            retrieve_latents(vae.encode(frames), sample_mode="argmax")], dim=2)
        x0 = ((x0.float() - mean) * inv_std)
        scheduler = pipe.scheduler
        scheduler.set_timesteps(_total_steps(steps, strength), device=self.device)
        first = scheduler.timesteps[-steps:][:1]
        noise = torch.randn(x0.shape, generator=generator, dtype=torch.float32).to(self.device)
        return scheduler.scale_noise(x0, first, noise)


def depth_control(frames: np.ndarray, depth: np.ndarray, object_id: np.ndarray, grow: int = 3):
    """(masks (T, H, W) bool, control frames (T, H, W, 3) uint8): the objects' pixels grown by ``grow`` pixels,
    and the frames with those pixels replaced by the depth pass as a grey depth map (inverse depth, scaled over
    the objects of the whole shot, near = white), as VACE's depth control expects."""
    import cv2

    kernel = np.ones((2 * grow + 1, 2 * grow + 1), np.uint8)
    masks = np.stack([cv2.dilate((ids > 0).astype(np.uint8), kernel) > 0 for ids in object_id])
    inv = 1.0 / np.maximum(depth, 1e-6)
    lo, hi = (float(inv[masks].min()), float(inv[masks].max())) if masks.any() else (0.0, 1.0)
    grey = (np.clip((inv - lo) / max(hi - lo, 1e-9), 0.0, 1.0) * 200 + 55).astype(np.uint8)
    control = np.where(masks[..., None], grey[..., None], frames).astype(np.uint8)
    return masks, control


def _total_steps(steps: int, strength: float) -> int:
    """Steps of the whole schedule of which the last ``steps`` are run."""
    return max(steps, int(math.ceil(steps / strength)))


def _truncate_schedule(scheduler, steps: int, strength: float) -> None:
    """Make the pipeline's own ``set_timesteps`` keep only the last ``steps`` timesteps (partial denoising)."""
    original = scheduler.set_timesteps

    def set_timesteps(num_inference_steps=None, device=None, **kwargs):
        original(num_inference_steps, device=device, **kwargs)
        scheduler.timesteps = scheduler.timesteps[-steps:]
        scheduler.sigmas = scheduler.sigmas[-(steps + 1):]
        scheduler._step_index = None
        scheduler._begin_index = None

    scheduler.set_timesteps = set_timesteps
