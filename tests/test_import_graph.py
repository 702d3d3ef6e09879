"""Imports flow one way: cli → apps (bench, batch, preview) → the public API → commands (build, validate,
rerender, the built-in backends) → stages in pipeline order (render may use physics, physics materials, …,
align texture, texture lift, lift perceive) → shared primitives (settings, the plugin interface) → usd/ → the
base (errors, file writing, warp loading). Each package sits on one layer: its modules share its rank.

Every module of the package is read with ``ast`` (imports inside functions count too) and each import of a
module ranked above the importer is listed. ``KNOWN_BACK_EDGES`` holds the ones not yet re-layered; the test
also fails when one of them is gone, so that the list only shrinks.
"""

from __future__ import annotations

import ast
import pathlib

import physomni_usd

ROOT = pathlib.Path(physomni_usd.__file__).resolve().parent

#: Layer of each module, by longest matching dotted prefix (package-relative); higher may import lower.
RANKS = {
    "errors": 0, "_files": 0, "_warp": 0, "_version": 0, "suggest": 0, "limits": 0,
    "usd": 1,
    "rotations": 2, "settings": 2, "report": 2, "metrics": 2, "geometry": 2, "sizes": 2, "fields": 2,
    "failure": 2,  # names a refused value by the option its settings field declares
    "swappable": 2,
    "perceive": 3,
    "lift": 4,
    "texture": 4.5,  # the plate and the textures: after lift, before (and after) align in the build's order
    "align": 5,
    "materials": 6,
    "physics": 7,
    "rendering": 8,
    "building": 9, "validate": 9, "backends": 9, "rerender": 9,
    "": 10,  # the package itself: its public API
    "bench": 11, "batch": 11, "preview": 11, "studio": 11,
    "cli": 12,
}

#: (importer, imported) pairs still running back up the layers; remove an entry when its edge is fixed.
KNOWN_BACK_EDGES: set[tuple[str, str]] = set()


def _modules() -> dict[str, pathlib.Path]:
    out = {}
    for path in ROOT.rglob("*.py"):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _rank(module: str) -> int:
    best = ""
    for prefix in RANKS:
        if (module == prefix or module.startswith(prefix + ".")) and len(prefix) >= len(best):
            best = prefix
    return RANKS[best]


def imports() -> set[tuple[str, str]]:
    """(importer, imported) module pairs inside the package, package-relative dotted names."""
    modules = _modules()
    edges = set()
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".") if package else []
                    base = base[:len(base) - (node.level - 1)]
                    base = ".".join(base + ([node.module] if node.module else []))
                    base = "physomni_usd" + ("." + base if base else "")
                else:
                    base = node.module or ""
                # ``from .x import y`` imports the module x.y where there is one, else x itself
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}"[len("physomni_usd."):] in modules else base
                           for a in node.names]
            for target in targets:
                if target != "physomni_usd" and not target.startswith("physomni_usd."):
                    continue
                rel = target[len("physomni_usd."):] if "." in target else ""
                if rel in modules:
                    edges.add((name, rel))
    return edges


def back_edges() -> set[tuple[str, str]]:
    return {(a, b) for a, b in imports() if _rank(b) > _rank(a)}


def test_every_module_has_a_layer():
    assert all(_rank(m) >= 0 for m in _modules())
    assert "physics.forces" in _modules() and ("physics.prepare", "physics.stability") in imports()


def test_each_package_has_one_rank():
    """A rank is given to a package or a top-level module, never to one module inside a package."""
    split = sorted(k for k in RANKS if "." in k)
    assert not split, f"modules ranked apart from their package: {', '.join(split)}"


def test_imports_flow_one_way():
    found = back_edges()
    new = sorted(found - KNOWN_BACK_EDGES)
    assert not new, "imports from a lower layer up to a higher one:\n" + "\n".join(f"  {a} → {b}" for a, b in new)


def test_known_back_edges_are_still_there():
    gone = sorted(KNOWN_BACK_EDGES - back_edges())
    assert not gone, "fixed: remove from KNOWN_BACK_EDGES:\n" + "\n".join(f"  {a} → {b}" for a, b in gone)


def test_no_module_imports_itself_through_others():
    """No import cycle between modules (physics/mpm.py and physics/objects.py imported each other)."""
    graph: dict[str, set[str]] = {}
    for a, b in imports():
        if b:  # every module imports the package itself, which holds only the lazy public API
            graph.setdefault(a, set()).add(b)
    done, path = set(), []

    def visit(m):
        if m in path:
            raise AssertionError("import cycle: " + " → ".join(path[path.index(m):] + [m]))
        if m in done:
            return
        path.append(m)
        for n in sorted(graph.get(m, ())):
            visit(n)
        path.pop()
        done.add(m)

    for m in sorted(graph):
        visit(m)


def test_no_module_patches_the_import_system():
    """Names are fixed by naming modules apart, not by rebinding ``sys.modules`` entries or swapping a module's
    class (the package once did both, to keep ``physomni_usd.build`` a function and old plugin paths alive)."""
    found = []
    for name, path in _modules().items():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            for target in getattr(node, "targets", None) or [getattr(node, "target", None)]:
                if isinstance(target, ast.Subscript) and ast.unparse(target.value) == "sys.modules":
                    found.append(f"{name}: {ast.unparse(target)} =")
                if isinstance(target, ast.Attribute) and target.attr == "__class__":
                    found.append(f"{name}: {ast.unparse(target)} =")
    assert not found, "\n".join(found)
