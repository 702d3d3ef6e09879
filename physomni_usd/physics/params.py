"""Which material parameters reach a solver as given, and which do not: every parameter an object's
type takes either acts in the simulation or is listed here per object, ignored or clamped, with the
reason and who set the value. The report lists every one (``ignored_parameters``); ``simulate`` says in
a line only those that a person or an estimator authored (``user``, ``vlm``): a value the tool chose
itself (the catalog's default, the rules estimator's) is no news to the user, who cannot have meant it.

| parameter | types | what happens |
|---|---|---|
| stretch / bending compliance | pbd_cloth | 1/compliance is the spring / bending stiffness, clamped to what XPBD keeps stable at our steps (``cloth.CLOTH_SPRING_KE``, ``CLOTH_BEND_KE``): clamped values are listed |
| stretch / volume compliance | pbd_elastic | 1/compliance are the Lamé stiffnesses, clamped to ``cloth.SOFT_KE``: clamped values are listed |
| bending_compliance | pbd_elastic | listed: a tetrahedral body has no bending constraint |
| air_resistance | pbd_cloth | acts: a drag −c·m·v on each particle of the cloth (``cloth.AirDrag``) |
| relaxation | pbd_elastic | acts: Newton's XPBD relaxes all tetrahedra with one factor, the smallest soft body's within ``cloth.SOFT_RELAXATION``; values it differs from are listed |
| density / viscosity relaxation | pbd_liquid | listed: Newton has no position-based fluid; pbd_liquid runs as MPM particles |
| model | MPM types | corotated acts (Newton's implicit MPM law); any other value is listed |
| friction, restitution | MPM types | listed: the MPM grid meets colliders with their friction, not the particles' |
| dynamic_friction | cloth, soft | acts: Newton's particle–shape friction (``soft_contact_mu``), one value for all particles; objects that disagree with the first are listed |
| static_friction | all | acts where it equals dynamic_friction; otherwise listed: Newton has one friction coefficient |
| restitution | cloth, soft | listed: XPBD takes no per-object restitution for particles |
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..materials.catalog import CATALOG
from .cloth import CLOTH_BEND_KE, CLOTH_SPRING_KE, SOFT_KE, SOFT_RELAXATION
from .mpm import MPM_LAW

PARTICLE_FAMILIES = ("cloth", "soft")
#: Who set a value when the tool chose it itself: nobody asked for it, so simulate does not say it is ignored.
TOOL_SOURCES = ("default", "rules")


def particle_friction(objects) -> float | None:
    """The friction coefficient of XPBD particle contacts: the first cloth or soft body's dynamic friction
    (None without one)."""
    for o in objects:
        if o.family in PARTICLE_FAMILIES and o.params.get("dynamic_friction") is not None:
            return float(o.params["dynamic_friction"])
    return None


def relaxation_of(obj) -> float:
    """A soft body's ``relaxation`` as authored, else the catalog's default for ``pbd_elastic``."""
    value = obj.params.get("relaxation")
    return float(CATALOG["pbd_elastic"].defaults["relaxation"] if value is None else value)


def soft_relaxation(objects) -> float | None:
    """The one relaxation Newton's XPBD gives all tetrahedra: the smallest soft body's
    (:func:`relaxation_of`) within ``cloth.SOFT_RELAXATION``; None without a soft body."""
    values = [relaxation_of(o) for o in objects if o.family == "soft"]
    return float(np.clip(min(values), *SOFT_RELAXATION)) if values else None


@dataclass(frozen=True)
class ParticleValues:
    """The one value each that Newton's XPBD gives all particles, whatever each object says: the contact
    friction (``soft_contact_mu``, :func:`particle_friction`) and the soft bodies' relaxation
    (:func:`soft_relaxation`); None where no object has one."""
    friction: float | None
    relaxation: float | None


def particle_values(objects) -> ParticleValues:
    """The :class:`ParticleValues` of ``objects``: what the model and its solver run with."""
    return ParticleValues(particle_friction(objects), soft_relaxation(objects))


def ignored_parameters(objects, shared: ParticleValues | None = None) -> dict[str, list[dict]]:
    """Per object name, the parameters that do not act as given: ``[{param, value, why, source}]``; the
    source is who set the value (an object without ``sources`` counts as the user's). ``shared``:
    :func:`particle_values` of ``objects``, when the caller has them already."""
    out = {}
    shared = shared or particle_values(objects)
    mu, relax = shared.friction, shared.relaxation
    for o in objects:
        sources = getattr(o, "sources", None) or {}
        items = [{"param": k, "value": _value(v), "why": why, "source": sources.get(k, "user")}
                 for k, v, why in _ignored(o, mu, relax)]
        if items:
            out[o.name] = items
    return out


def authored(items: list[dict]) -> list[dict]:
    """The items whose value a person or an estimator authored: those simulate says."""
    return [i for i in items if i.get("source") not in TOOL_SOURCES]


def describe(name: str, items: list[dict]) -> str:
    """One line for an object's list."""
    return f"{name}: " + "; ".join(f"{i['param']} = {_show(i['value'])} {i['why']}" for i in items)


def _ignored(o, mu, relax):
    p, fam, kind = o.params, o.family, o.kind
    if fam == "cloth":
        yield from _clamped(p, "stretch_compliance", CLOTH_SPRING_KE, "N/m", "spring")
        yield from _clamped(p, "bending_compliance", CLOTH_BEND_KE, "N·m", "bending")
    if fam == "soft":
        yield from _clamped(p, "stretch_compliance", SOFT_KE, "Pa", "shear")
        yield from _clamped(p, "volume_compliance", SOFT_KE, "Pa", "volume")
        if "bending_compliance" in p:
            yield "bending_compliance", p["bending_compliance"], "is ignored: a tetrahedral soft body has no " \
                                                                 "bending constraint"
        if "relaxation" in p and relax is not None and abs(relaxation_of(o) - relax) > 1e-6 * relax:
            yield "relaxation", p["relaxation"], f"ran as {relax:g}: Newton's XPBD relaxes every soft body with " \
                                                 "one factor, the smallest authored, at most 0.1 (a larger one " \
                                                 "overshoots and the body flies apart)"
    if kind == "pbd_liquid":
        for key in ("density_relaxation", "viscosity_relaxation"):
            if key in p:
                yield key, p[key], "is ignored: Newton has no position-based fluid, so pbd_liquid runs as MPM " \
                                   "liquid particles, which have no relaxation"
    if fam == "mpm":
        if p.get("model") not in (None, MPM_LAW):
            yield "model", p["model"], f"is ignored: Newton's implicit MPM has one elastic law; it ran as {MPM_LAW}"
        for key in ("static_friction", "dynamic_friction", "restitution"):
            if key in p:
                yield key, p[key], "is ignored: Newton's MPM grid meets colliders with the colliders' own " \
                                   "friction; particles carry no contact friction or restitution"
        return
    if fam in PARTICLE_FAMILIES:
        if p.get("dynamic_friction") is not None and mu is not None and float(p["dynamic_friction"]) != mu:
            yield "dynamic_friction", p["dynamic_friction"], f"is ignored: Newton gives all particle contacts " \
                                                             f"one friction; it ran with {mu:g}, the first " \
                                                             "cloth's or soft body's"
        if "restitution" in p:
            yield "restitution", p["restitution"], "is ignored: XPBD takes no per-object restitution for particles"
    if "static_friction" in p and p["static_friction"] != p.get("dynamic_friction"):
        yield "static_friction", p["static_friction"], "is ignored: Newton's contacts have one friction " \
                                                       "coefficient, dynamic_friction"


def _clamped(p, key, bounds, unit, what):
    if key not in p:
        return
    c = float(p[key] or 0.0)
    k = 1.0 / c if c > 0 else float("inf")
    lo, hi = bounds
    if not lo <= k <= hi:
        edge = hi if k > hi else lo
        yield key, p[key], (f"is clamped to {1 / edge:g} ({what} stiffness {edge:g} {unit}): the simulator keeps "
                            f"XPBD stiffness within [{lo:g}, {hi:g}] {unit}, what stays stable at its steps")


def _value(value):
    """A number as authored: USD floats are single precision, so 0.4 reads back as 0.4000000059604645."""
    return float(f"{value:.7g}") if isinstance(value, float) else value


def _show(value) -> str:
    return f"{value:g}" if isinstance(value, (int, float)) and not isinstance(value, bool) else str(value)
