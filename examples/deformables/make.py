"""Paint the four deformable examples (a studio floor, a backdrop, flat-shaded props) and their masks.

Run from the repository root: ``python examples/deformables/make.py``. Each folder it writes —
``jelly``, ``sand``, ``water``, ``cloth`` — holds photo.png, one PNG mask per object and
example.json; labels pick the materials (jelly → mpm_elastic, sand → mpm_sand, water →
mpm_liquid, towel → pbd_cloth; crate → rigid).
"""

from __future__ import annotations

import json
import pathlib

import cv2
import numpy as np

W, H = 480, 320
HORIZON = 150
HERE = pathlib.Path(__file__).resolve().parent


def backdrop(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = np.zeros((H, W, 3), np.float32)
    img[:HORIZON] = np.linspace(170, 205, HORIZON)[:, None, None] * np.array([0.92, 0.95, 1.0])
    img[HORIZON:] = np.linspace(140, 95, H - HORIZON)[:, None, None] * np.array([1.0, 0.88, 0.74])
    return img + rng.normal(0, 3, (H, W, 1))


def paint(img: np.ndarray, mask: np.ndarray, rgb, seed: int) -> None:
    rng = np.random.default_rng(seed)
    shade = np.linspace(0.75, 1.1, W)[None, :, None]
    img[:] = np.where(mask[..., None] > 0, np.array(rgb, np.float32) * shade, img)
    img[mask > 0] += rng.normal(0, 5, (int((mask > 0).sum()), 1))


def crate(x0: int, x1: int, top: int, bottom: int) -> np.ndarray:
    m = np.zeros((H, W), np.uint8)
    cv2.rectangle(m, (x0, top), (x1, bottom), 1, -1)
    return m


def write(name: str, img: np.ndarray, masks: dict, push: list[str], seconds: float, note: str) -> None:
    folder = HERE.parent / name
    folder.mkdir(exist_ok=True)
    cv2.imwrite(str(folder / "photo.png"), cv2.cvtColor(np.clip(img, 0, 255).astype(np.uint8), cv2.COLOR_RGB2BGR))
    for label, m in masks.items():
        cv2.imwrite(str(folder / f"{label}.png"), (m > 0).astype(np.uint8) * 255)
    spec = {"photo": "photo.png", "masks": [f"{k}.png:{k}" for k in masks], "push": push, "seconds": seconds,
            "note": note}
    (folder / "example.json").write_text(json.dumps(spec, indent=2) + "\n")


def main() -> None:
    # jelly: a green dome pushed into a crate
    img = backdrop(1)
    jelly = np.zeros((H, W), np.uint8)
    cv2.ellipse(jelly, (150, 250), (55, 60), 0, 180, 360, 1, -1)
    cv2.rectangle(jelly, (95, 250), (205, 262), 1, -1)
    box = crate(300, 400, 170, 262)
    paint(img, jelly, (90, 190, 80), 2)
    paint(img, box, (150, 110, 70), 3)
    write("jelly", img, {"jelly": jelly, "crate": box}, ["jelly=2.5,0,0"], 2.0,
          "an elastic dome (mpm_elastic) squashes against a crate and bounces back")
    # sand: a tall pile that collapses
    img = backdrop(4)
    sand = np.zeros((H, W), np.uint8)
    cv2.fillConvexPoly(sand, np.array([[180, 270], [300, 270], [265, 130], [215, 130]]), 1)
    paint(img, sand, (210, 180, 120), 5)
    write("sand", img, {"sand": sand}, [], 2.0, "a column of sand (mpm_sand) slumps into a pile")
    # water: a block of water that splashes against a crate
    img = backdrop(6)
    water = crate(110, 200, 140, 265)
    box = crate(300, 380, 200, 265)
    paint(img, water, (70, 120, 200), 7)
    paint(img, box, (150, 110, 70), 8)
    write("water", img, {"water": water, "crate": box}, ["water=1.5,0,0"], 2.0,
          "a block of water (mpm_liquid) breaks and splashes against a crate")
    # cloth: a towel standing beside a crate falls over it
    img = backdrop(9)
    towel = crate(170, 250, 90, 262)
    box = crate(270, 390, 205, 262)
    paint(img, towel, (200, 60, 60), 10)
    paint(img, box, (150, 110, 70), 11)
    write("cloth", img, {"towel": towel, "crate": box}, ["towel=1.2,0,0"], 2.0,
          "a towel (pbd_cloth) tips over and drapes across a crate")


if __name__ == "__main__":
    main()
