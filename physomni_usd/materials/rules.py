"""The built-in estimator: label keywords (and the object's colour) to a material and its parameters.

| keywords | material | notes |
|---|---|---|
| water, juice, milk, wine, liquid, soup, drink, oil, honey, syrup | mpm_liquid | honey and syrup get viscosity 10 Pa·s |
| sand, sandcastle, powder, flour, sugar, salt, soil, dirt, grain | mpm_sand | |
| snow, snowman, snowball | mpm_snow | |
| clay, dough, plasticine, cream, butter, mud, putty | mpm_elastoplastic | |
| jelly, jello, pudding, slime, gummy, marshmallow | mpm_elastic | E = 2e4 Pa |
| cloth, towel, flag, shirt, blanket, napkin, curtain, scarf, fabric, tablecloth | pbd_cloth | |
| sponge, foam | pbd_elastic | |
| anything else | rigid | density and friction from the rigid table of ``defaults.py`` |

Rigid objects that nothing in the table names get the paper's default
(ρ = 200 kg/m³, μ = 0.7). The colour of every object is its mean colour in
the photo (a cue the renderer uses for particles).
"""

from __future__ import annotations

import re

import numpy as np

from .config import ObjectConfig, SceneConfig
from .defaults import rigid_material

_TABLE = [
    (("water", "juice", "milk", "wine", "liquid", "soup", "drink", "oil", "honey", "syrup"), "mpm_liquid", {}),
    (("sand", "sandcastle", "powder", "flour", "sugar", "salt", "soil", "dirt", "grain"), "mpm_sand", {}),
    (("snow", "snowman", "snowball"), "mpm_snow", {}),
    (("clay", "dough", "plasticine", "cream", "butter", "mud", "putty"), "mpm_elastoplastic", {}),
    (("jelly", "jello", "pudding", "slime", "gummy", "marshmallow"), "mpm_elastic", {"youngs_modulus": 2e4}),
    (("cloth", "towel", "flag", "shirt", "blanket", "napkin", "curtain", "scarf", "fabric", "tablecloth"),
     "pbd_cloth", {}),
    (("sponge", "foam"), "pbd_elastic", {}),
]
_VISCOUS = {"honey": 10.0, "syrup": 10.0}


def _words(label: str) -> set[str]:
    words = set(re.split(r"[^a-z]+", label.lower())) - {""}
    return words | {w[:-1] for w in words if w.endswith("s")}


def estimate_object(index: int, label: str, color=None) -> ObjectConfig:
    words = _words(label)
    for keys, material, params in _TABLE:
        if words & set(keys):
            params = dict(params)
            for word, mu in _VISCOUS.items():
                if word in words:
                    params["viscosity"] = mu
            return ObjectConfig(index, material, params, identity=label, color=color, source="rules")
    mat = rigid_material(label)
    params = {"density": mat.density, "static_friction": mat.static_friction,
              "dynamic_friction": mat.dynamic_friction, "restitution": mat.restitution}
    return ObjectConfig(index, "rigid", params, identity=label, color=color, source="rules")


def mean_colour(photo: np.ndarray, mask: np.ndarray) -> tuple[float, float, float]:
    """Mean RGB of the object's pixels, in [0, 1]."""
    return tuple(float(c) for c in (photo[mask.astype(bool)].mean(axis=0) / 255.0).round(4))


def estimate_rules(labels: list[str], photo=None, masks=None) -> SceneConfig:
    """One configuration per object, in mask order; no force fields."""
    objects = []
    for i, label in enumerate(labels):
        color = mean_colour(photo, masks[i]) if photo is not None and masks is not None else None
        objects.append(estimate_object(i, label, color))
    return SceneConfig(objects, [], [], "rules")
