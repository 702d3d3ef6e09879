"""The default rigid materials, looked up by keywords of an object's label.

Densities are *effective*: the mass of the object divided by the volume of
its closed mesh. Lifted meshes are solid, so hollow things (cups, boxes,
bottles) get far less than their wall material's density.

| keywords                                        | ρ kg/m³ | μ static | μ dynamic | e    |
|-------------------------------------------------|---------|----------|-----------|------|
| ball, balloon                                   | 150     | 0.8      | 0.7       | 0.6  |
| box, carton, package, parcel, bin               | 120     | 0.5      | 0.45      | 0.1  |
| cup, mug, bowl, vase, glass, jar, saucer, plate | 700     | 0.4      | 0.35      | 0.2  |
| bottle, can                                     | 300     | 0.4      | 0.35      | 0.2  |
| spoon, fork, knife, metal, tool, key            | 2000    | 0.35     | 0.3       | 0.3  |
| rock, stone, brick                              | 2400    | 0.7      | 0.65      | 0.1  |
| wood, bench, chair, table, block, crate, shelf  | 500     | 0.6      | 0.5       | 0.15 |
| fruit, apple, orange, lemon, lime, pear, banana, egg | 950 | 0.5   | 0.45      | 0.2  |
| toy, plush, teddy, doll, pillow, cushion        | 150     | 0.9      | 0.8       | 0.05 |
| motorcycle, bike, bicycle, car, vehicle, rocket | 400     | 0.8      | 0.7       | 0.1  |
| anything else                                   | 200     | 0.7      | 0.7       | 0.1  |

The last row is the paper's rigid default (ρ = 200, μ = 0.7).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..usd.author import PhysicsObject


@dataclass(frozen=True)
class RigidMaterial:
    name: str
    density: float  # kg/m³
    static_friction: float
    dynamic_friction: float
    restitution: float


_TABLE = [
    (("ball", "balloon"), RigidMaterial("rubber", 150.0, 0.8, 0.7, 0.6)),
    (("box", "carton", "package", "parcel", "bin"), RigidMaterial("cardboard", 120.0, 0.5, 0.45, 0.1)),
    (("cup", "mug", "bowl", "vase", "glass", "jar", "saucer", "plate"), RigidMaterial("ceramic", 700.0, 0.4, 0.35, 0.2)),
    (("bottle", "can"), RigidMaterial("bottle", 300.0, 0.4, 0.35, 0.2)),
    (("spoon", "fork", "knife", "metal", "tool", "key"), RigidMaterial("metal", 2000.0, 0.35, 0.3, 0.3)),
    (("rock", "stone", "brick"), RigidMaterial("stone", 2400.0, 0.7, 0.65, 0.1)),
    (("wood", "bench", "chair", "table", "block", "crate", "shelf"), RigidMaterial("wood", 500.0, 0.6, 0.5, 0.15)),
    # a lemon or a lime is as dense as an orange; under the default row it weighed a fifth of one (200 kg/m³)
    (("fruit", "apple", "orange", "lemon", "lime", "pear", "banana", "egg"),
     RigidMaterial("fruit", 950.0, 0.5, 0.45, 0.2)),
    (("toy", "plush", "teddy", "doll", "pillow", "cushion"), RigidMaterial("soft", 150.0, 0.9, 0.8, 0.05)),
    (("motorcycle", "bike", "bicycle", "car", "vehicle", "rocket"), RigidMaterial("vehicle", 400.0, 0.8, 0.7, 0.1)),
]

DEFAULT = RigidMaterial("default", 200.0, 0.7, 0.7, 0.1)
GROUND = RigidMaterial("ground", 1000.0, 0.7, 0.7, 0.1)
#: The ground's physics material as the physics layer authors it.
GROUND_MATERIAL = PhysicsObject("Ground", "rigid", {"density": GROUND.density,
                                                    "static_friction": GROUND.static_friction,
                                                    "dynamic_friction": GROUND.dynamic_friction,
                                                    "restitution": GROUND.restitution}, "rules")


def rigid_material(label: str) -> RigidMaterial:
    """The table's material for the first keyword found among the label's words."""
    words = set(re.split(r"[^a-z]+", label.lower()))
    words |= {w[:-1] for w in words if w.endswith("s")}  # plurals: 'boxes' is not handled, 'cups' is
    for keys, mat in _TABLE:
        if words & set(keys):
            return mat
    return DEFAULT
