"""A physics configuration of a scene: one material per object plus force fields, each with its source."""

from __future__ import annotations

from dataclasses import dataclass, field

from .catalog import CATALOG, check_params


@dataclass
class ObjectConfig:
    index: int
    material: str
    params: dict  # canonical keys, validated, defaults filled in
    identity: str = ""
    fixed: bool = False
    color: tuple[float, float, float] | None = None
    source: str = "rules"
    size_m: float | None = None  # the object's real longest dimension, where the estimator gives one

    def __post_init__(self):
        if self.material not in CATALOG:
            raise ValueError(f"unknown material type {self.material!r}")
        self.params = check_params(self.material, self.params)


@dataclass
class SceneConfig:
    objects: list[ObjectConfig]
    forces: list = field(default_factory=list)  # fields.ForceField
    warnings: list[str] = field(default_factory=list)
    source: str = "rules"
