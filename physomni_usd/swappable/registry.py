"""Backends by kind and name: the built-ins, and plugins found through entry points.

A plugin declares, in its ``pyproject.toml``::

    [project.entry-points."physomni_usd.backends"]
    "inpainter.lama" = "physomni_lama:LamaInpainter"

i.e. ``KIND.NAME = module:Class``. Listing reads only the installed
distributions' metadata; a plugin's module is imported when it is selected
(or when ``physomni-usd plugins`` asks it whether it is ready), so that a run
that uses only built-ins imports no torch.
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import os
import pathlib
from dataclasses import dataclass
from importlib import metadata

from ..errors import InputError

GROUP = "physomni_usd.backends"
KINDS = ("segmenter", "inpainter", "outpainter", "lifter", "depth", "estimator", "rerenderer", "finder")

#: Built-in backends: (kind, name) → "module:Class".
BUILTINS = {
    ("segmenter", "grabcut"): "physomni_usd.backends.builtin:GrabCutSegmenter",
    ("inpainter", "builtin"): "physomni_usd.backends.builtin:BuiltinInpainter",
    ("outpainter", "mirror"): "physomni_usd.backends.builtin:MirrorOutpainter",
    ("outpainter", "exemplar"): "physomni_usd.backends.builtin:ExemplarOutpainter",
    ("lifter", "silhouette"): "physomni_usd.backends.builtin:SilhouetteLifter",
    ("estimator", "rules"): "physomni_usd.backends.builtin:RulesEstimator",
    ("estimator", "vlm"): "physomni_usd.backends.builtin:VLMEstimator",
}
#: What each step uses when no option names a backend (None: the step is skipped).
DEFAULTS = {"segmenter": "grabcut", "inpainter": "builtin", "outpainter": "exemplar", "lifter": "silhouette",
            "depth": None, "estimator": "rules", "rerenderer": None, "finder": None}
#: The plugin to install for each kind that has no built-in.
SUGGESTED = {"outpainter": None, "depth": "physomni-depth", "rerenderer": "physomni-wan", "finder": "physomni-sam3"}


@dataclass
class Entry:
    kind: str
    name: str
    target: str  # "module:Class"
    package: str  # distribution name ("physomni-usd" for built-ins)
    version: str

    @property
    def builtin(self) -> bool:
        return self.package == "physomni-usd"

    def load(self):
        """The backend class (imports its module)."""
        module, _, attr = self.target.partition(":")
        obj = importlib.import_module(module)
        for part in attr.split("."):
            obj = getattr(obj, part)
        return obj


@functools.lru_cache(maxsize=1)  # each lookup scans every installed distribution's metadata
def _own_version() -> str:
    try:
        return metadata.version("physomni-usd")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
        from .._version import __version__

        return __version__


def entries() -> list[Entry]:
    """Every backend, built-ins first, then plugins in name order; never imports a plugin."""
    out = [Entry(k, n, t, "physomni-usd", _own_version()) for (k, n), t in BUILTINS.items()]
    seen = {(e.kind, e.name) for e in out}
    plugins = []
    for ep in metadata.entry_points(group=GROUP):
        kind, dot, name = ep.name.partition(".")
        if not dot or kind not in KINDS or (kind, name) in seen:
            continue
        dist = getattr(ep, "dist", None)
        plugins.append(Entry(kind, name, ep.value, dist.name if dist else "?", dist.version if dist else "?"))
        seen.add((kind, name))
    return out + sorted(plugins, key=lambda e: (KINDS.index(e.kind), e.name))


def find(kind: str, name: str) -> Entry:
    """The entry for ``name`` of ``kind``; one line naming what exists when there is none."""
    option = "--depth" if kind == "depth" else ("--model" if kind == "rerenderer" else f"--{kind}")
    known = [e for e in entries() if e.kind == kind]
    for e in known:
        if e.name == name:
            return e
    names = ", ".join(e.name for e in known)
    if names:
        raise InputError(f"{option} {name}: no such {kind}; installed: {names}")
    hint = SUGGESTED.get(kind)
    install = f" (install a plugin such as {hint}: pip install -e plugins/{hint})" if hint else ""
    raise InputError(f"{option} {name}: no {kind} backend is installed{install}")


def load(kind: str, name: str, **options):
    """An instance of backend ``name`` of ``kind``, checked ready; otherwise one line and exit code 2."""
    entry = find(kind, name)
    try:
        cls = entry.load()
    except ImportError as exc:
        raise InputError(f"{entry.package} ({kind} {name}) cannot be imported: {exc}; "
                         f"reinstall it with its extra: pip install '{entry.package}[models]'") from None
    lack = cls.missing()
    if lack:
        raise InputError(lack)
    backend = cls(**options)
    backend.entry = entry
    return backend


def describe(backend) -> dict:
    """What ``report.json`` records of a backend that ran: name, package, version, weights."""
    entry = getattr(backend, "entry", None)
    out = {"name": type(backend).name, "builtin": bool(entry and entry.builtin)}
    if entry is not None:
        out.update(package=entry.package, version=entry.version)
    out["weights"] = type(backend).weights()
    return out


def status(entry: Entry) -> tuple[bool, str]:
    """(ready, what it lacks or where its weights are) for ``physomni-usd plugins``; imports the plugin."""
    try:
        cls = entry.load()
    except Exception as exc:  # a broken plugin must not stop the listing
        return False, f"cannot be imported ({type(exc).__name__}: {exc})"
    try:
        lack = cls.missing()
        weights = cls.weights()
    except Exception as exc:
        return False, f"cannot check ({type(exc).__name__}: {exc})"
    if lack:
        return False, lack
    note = getattr(cls, "note", None)
    return True, note() if note else (f"weights {weights}" if weights else "")


def lacking_modules(modules, who: str, extra: str) -> str | None:
    """For a plugin's ``missing()``: one line naming those of ``modules`` that are not installed and the
    ``pip install`` that brings them (``extra``, e.g. ``physomni-lama[models]``), or None."""
    lacking = [m for m in modules if importlib.util.find_spec(m) is None]
    if not lacking:
        return None
    names = lacking[0] if len(lacking) == 1 else f"{', '.join(lacking[:-1])} and {lacking[-1]}"
    return f"{who} needs {names}: pip install '{extra}'"


def weights_problem(env: str, what: str, inside: str | None = None) -> str | None:
    """For a plugin's ``missing()``: one line saying what is wrong with the weights the environment variable
    ``env`` names — unset, not a file (``inside`` None), or a folder without ``inside`` — or None."""
    path = os.environ.get(env) or None
    if not path:
        return f"{env} is not set: point it at {what}"
    if inside is None and not pathlib.Path(path).is_file():
        return f"{env}={path} is not a file: point it at {what}"
    if inside is not None and not (pathlib.Path(path) / inside).is_file():
        return f"{env}={path} has no {inside}: point it at {what}"
    return None
