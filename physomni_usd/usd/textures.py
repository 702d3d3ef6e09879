"""Reading the texture bound to a prim: its file (through UsdShade) and its pixels."""

from __future__ import annotations

import pathlib

import cv2
import numpy as np
from pxr import Usd, UsdShade

from ..errors import InputError


def texture_file(prim: Usd.Prim) -> pathlib.Path | None:
    """Resolved file of the UsdUVTexture feeding the surface bound to ``prim`` (default purpose)."""
    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    if not mat:
        return None
    for shader_prim in Usd.PrimRange(mat.GetPrim()):
        shader = UsdShade.Shader(shader_prim)
        if shader and shader.GetIdAttr().Get() == "UsdUVTexture":
            asset = shader.GetInput("file").Get()
            if asset is not None and (asset.resolvedPath or asset.path):
                p = pathlib.Path(asset.resolvedPath or asset.path)
                if not p.is_absolute():
                    p = pathlib.Path(prim.GetStage().GetRootLayer().realPath).parent / p
                return p
    return None


def read_image(path: pathlib.Path, what: str, rgba: bool) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED) if path and path.is_file() else None
    if img is None:
        raise InputError(f"cannot read the {what} texture {path}; was the shot folder moved without textures/?")
    if img.ndim == 2:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    if img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
        if rgba:
            img = np.dstack([img, np.full(img.shape[:2], 255, np.uint8)])
    else:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGBA)
        if not rgba:
            img = img[..., :3]
    return np.ascontiguousarray(img)
