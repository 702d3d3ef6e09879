"""The VLM estimator: the paper's prompt, the photo and one crop per object, any OpenAI-compatible server.

The endpoint is ``POST {url}/chat/completions`` (vLLM, Ollama, LM Studio, a
hosted API); ``url`` is the API root, e.g. ``http://localhost:8000/v1``.
Images travel as base64 PNG ``image_url`` parts. Only the standard library
talks HTTP, so the estimator adds no dependency.
"""

from __future__ import annotations

import base64
import json
import os
import socket
import time
import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass, field

import numpy as np

from ..errors import PhysOmniError, redact
from ..limits import Limit, Limits
from ..fields import FIELD_KINDS
from .parse import parse_reply

ENV_URL, ENV_MODEL, ENV_KEY = "PHYSOMNI_VLM_URL", "PHYSOMNI_VLM_MODEL", "PHYSOMNI_VLM_API_KEY"

SYSTEM_PROMPT = """You are an expert physics material analyst and simulation designer. You will see a scene image, \
then cropped images of individual objects, numbered from 0 in the order shown.

Task A - object materials. For each object give:
1. what the object is (e.g. sand castle, rubber duck);
2. the physics material type that best fits an interesting deformable simulation; prefer the most deformable \
plausible reading. Types:
   MPM (particles): "mpm_liquid" (liquids, viscous fluids; params E, nu, rho, viscosity), "mpm_elastoplastic" \
(permanent deformation: clay, cream; params E, nu, rho, yield_stress), "mpm_elastic" (rubber, jelly; params E, nu, \
rho), "mpm_sand" (sand, powder; params E, nu, rho, friction_angle), "mpm_snow" (snow, ice; params E, nu, rho, \
critical_compression, critical_stretch);
   PBD: "pbd_cloth" (fabric, paper; params rho in kg/m^2, friction, stretch_compliance, air_resistance), \
"pbd_elastic" (sponge; params rho, friction, stretch_compliance), "pbd_liquid" (params rho, density_relaxation, \
viscosity_relaxation);
   "rigid": only for immovable structures (ground, wall, table), never for small or deformable objects.
3. material_params in SI units: E Young's modulus in Pa (foam ~1e4, jelly ~1e3, rubber ~1e6, glass ~1e5), rho \
density in kg/m^3 (foam ~50, cream ~500, rubber ~1100, clay ~1800, glass ~2500), nu Poisson's ratio (typically \
0.2-0.45, nearly incompressible ~0.45);
4. fixed: true only if the object is truly static;
5. surface_color: RGB floats in [0, 1];
6. size_m: the object's real longest dimension in metres, judged from what it is and from the scene (a coin \
~0.024, a pencil ~0.19, a mug ~0.12, a chair ~0.9, a car ~4.5).

Task B - force fields. Suggest 1 to 3 force fields for interesting motion, of types {kinds}; \
each with direction [x, y, z] (Z is up), strength in m/s^2 and start_frame (-1 = immediately). \
Gravity is already applied; do not add it.

Answer with ONLY one JSON object: {"objects": [{"index": 0, "name": "...", "material": "...", \
"material_params": {...}, "fixed": false, "surface_color": [r, g, b], "size_m": 0.1}, ...], "forces": [{"type": "...", \
"direction": [x, y, z], "strength": s, "start_frame": -1}, ...]}""".replace(
    "{kinds}", ", ".join(k.name for k in FIELD_KINDS if k.suggested))


#: The numbers of the VLM call that the command line takes (``estimate --vlm-timeout``).
LIMITS = Limits(timeout_s=Limit("--vlm-timeout", "Seconds to wait for one answer.", 1, 3600, 120.0))


@dataclass
class VLMSettings:
    url: str
    model: str
    api_key: str | None = field(default=None, repr=False)  # never printed, never in a report
    timeout_s: float = LIMITS["timeout_s"].default
    retries: int = 2
    backoff_s: float = 1.0

    @classmethod
    def resolve(cls, url=None, model=None, api_key=None, **kw) -> "VLMSettings":
        """Options first, then PHYSOMNI_VLM_URL / PHYSOMNI_VLM_MODEL / PHYSOMNI_VLM_API_KEY; a number of
        :data:`LIMITS` out of its range is refused."""
        LIMITS.check(**{k: v for k, v in kw.items() if k in LIMITS})
        url = url or os.environ.get(ENV_URL)
        model = model or os.environ.get(ENV_MODEL)
        if not url:
            raise PhysOmniError(f"the vlm estimator needs a server: give --vlm-url or set {ENV_URL} "
                                "(an OpenAI-compatible API root such as http://localhost:8000/v1)", 2)
        if not model:
            raise PhysOmniError(f"the vlm estimator needs a model name: give --vlm-model or set {ENV_MODEL}", 2)
        return cls(url.rstrip("/"), model, api_key or os.environ.get(ENV_KEY), **kw)


def png_data_url(rgb_or_rgba: np.ndarray) -> str:
    img = rgb_or_rgba
    import cv2  # here, not at the top: the command line reads LIMITS without loading OpenCV
    code = cv2.COLOR_RGBA2BGRA if img.shape[2] == 4 else cv2.COLOR_RGB2BGR
    ok, data = cv2.imencode(".png", cv2.cvtColor(img, code))
    if not ok:
        raise PhysOmniError("cannot encode an image for the VLM")
    return "data:image/png;base64," + base64.b64encode(data.tobytes()).decode()


def object_crop(photo: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The object's box padded by max(10 px, 10 % of its longer side), cut with the mask itself (RGBA).

    The mask is used as a mask (non-zero = object), never read as a luminance.
    """
    ys, xs = np.nonzero(mask)
    h, w = mask.shape
    side = max(xs.max() - xs.min() + 1, ys.max() - ys.min() + 1)
    pad = int(max(10, round(0.1 * side)))
    x0, x1 = max(0, xs.min() - pad), min(w, xs.max() + 1 + pad)
    y0, y1 = max(0, ys.min() - pad), min(h, ys.max() + 1 + pad)
    alpha = (mask[y0:y1, x0:x1] > 0).astype(np.uint8) * 255
    return np.dstack([photo[y0:y1, x0:x1], alpha])


def build_messages(photo: np.ndarray, masks: list[np.ndarray], labels: list[str]) -> list[dict]:
    content = [{"type": "text", "text": "Scene image:"},
               {"type": "image_url", "image_url": {"url": png_data_url(photo)}}]
    for i, (mask, label) in enumerate(zip(masks, labels)):
        content.append({"type": "text", "text": f"Object {i} (the user calls it '{label}'):"})
        content.append({"type": "image_url", "image_url": {"url": png_data_url(object_crop(photo, mask))}})
    return [{"role": "system", "content": SYSTEM_PROMPT}, {"role": "user", "content": content}]


class _SameHostRedirects(urllib.request.HTTPRedirectHandler):
    """Follow a redirect only to the host (and port and scheme) the user named: the API key goes nowhere
    else, and an answer from elsewhere is not taken for the server's."""

    def redirect_request(self, req, fp, code, msg, headers, newurl):
        old, new = urllib.parse.urlsplit(req.full_url), urllib.parse.urlsplit(newurl)
        if (old.scheme, old.hostname, old.port) != (new.scheme, new.hostname, new.port):
            raise PhysOmniError(f"VLM server at {redact(req.full_url)} redirected to another host "
                                f"({redact(newurl)}); the request (and its API key) goes only to the host "
                                "given in --vlm-url: give the new address there")
        return super().redirect_request(req, fp, code, msg, headers, newurl)


_OPENER = urllib.request.build_opener(_SameHostRedirects)


def chat(settings: VLMSettings, messages: list[dict]) -> str:
    """The reply text of one chat completion, with retries on timeouts, lost connections and 5xx/429."""
    body = json.dumps({"model": settings.model, "messages": messages, "temperature": 0.2,
                       "max_tokens": 2048}).encode()
    headers = {"Content-Type": "application/json"}
    parts = urllib.parse.urlsplit(settings.url)
    if settings.api_key:
        headers["Authorization"] = f"Bearer {settings.api_key}"
    elif parts.username is not None:  # http://user:password@host/v1: HTTP basic authentication
        pair = f"{urllib.parse.unquote(parts.username)}:{urllib.parse.unquote(parts.password or '')}"
        headers["Authorization"] = "Basic " + base64.b64encode(pair.encode()).decode()
    bare = parts._replace(netloc=parts.netloc.rpartition("@")[2])  # urllib would take user:secret for the host
    endpoint = f"{urllib.parse.urlunsplit(bare)}/chat/completions"
    last = "no attempt made"
    for attempt in range(settings.retries + 1):
        if attempt:
            time.sleep(settings.backoff_s * 2 ** (attempt - 1))
        request = urllib.request.Request(endpoint, data=body, headers=headers, method="POST")
        try:
            with _OPENER.open(request, timeout=settings.timeout_s) as response:
                payload = json.loads(response.read().decode("utf-8", errors="replace"))
            return _reply_text(payload)
        except urllib.error.HTTPError as exc:
            last = f"HTTP {exc.code} {exc.reason}"
            if exc.code not in (408, 429) and exc.code < 500:
                raise PhysOmniError(f"VLM server at {settings.url} refused the request: {last}") from None
        except (urllib.error.URLError, ConnectionError) as exc:
            reason = getattr(exc, "reason", exc)
            last = f"cannot reach it ({reason})"
        except (TimeoutError, socket.timeout):
            last = f"no answer within {settings.timeout_s:g} s"
        except (ValueError, KeyError, IndexError, TypeError):
            last = "its answer is not an OpenAI chat-completions response"
    raise PhysOmniError(f"VLM server at {settings.url}: {last} (after {settings.retries + 1} attempts)")


def _reply_text(payload: dict) -> str:
    content = payload["choices"][0]["message"]["content"]
    if isinstance(content, list):  # some servers return content parts
        content = "".join(part.get("text", "") for part in content if isinstance(part, dict))
    return str(content)


def estimate_vlm(settings: VLMSettings, photo: np.ndarray, masks: list[np.ndarray], labels: list[str],
                 fps: float = 30.0):
    """Ask the VLM and parse its reply into a configuration (source ``vlm``)."""
    reply = chat(settings, build_messages(photo, masks, labels))
    cfg = parse_reply(reply, len(labels), fps)
    for obj, label in zip(cfg.objects, labels):
        obj.identity = obj.identity or label
    return cfg
