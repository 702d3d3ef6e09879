"""The docs name only what exists: every path or dotted name of the package that a docstring, the README
or a page under docs/ gives.

Three forms are read: ``physomni_usd/...`` paths (from the repository's root), paths inside the package
as docstrings write them (``materials/catalog.py``, ``usd/``), and dotted names
(``physomni_usd.usd.contract.object_prims``): the longest dotted prefix that is a module must exist, and
what follows it must be defined at the top of that module (or be one of its classes' members).
"""

from __future__ import annotations

import ast
import pathlib
import re

import physomni_usd

PACKAGE = pathlib.Path(physomni_usd.__file__).resolve().parent
ROOT = PACKAGE.parent
PACKAGES = sorted(p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file())

SLASHED = re.compile(r"(?<![\w./-])(physomni_usd/[\w./-]*[\w/])")
INSIDE = re.compile(r"(?<![\w./-])((?:%s)/(?:[\w-]+/)*(?:[\w*-]+(?:\.\w+)*/?)?)(?![\w/])" % "|".join(PACKAGES))
DOTTED = re.compile(r"(?<![\w./-])(physomni_usd(?:\.[A-Za-z_]\w*)+)")


def _docstrings(path: pathlib.Path):
    tree = ast.parse(path.read_text(), str(path))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                yield doc


def texts():
    """(where, text) of every docstring of the package and every Markdown page of its docs."""
    for path in sorted(PACKAGE.rglob("*.py")):
        if "_schema" in path.parts:
            continue
        for doc in _docstrings(path):
            yield path.relative_to(ROOT), doc
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))] if (ROOT / "docs").is_dir() else [
        ROOT / "README.md"]
    for page in pages:
        if page.is_file() and "pending" not in page.relative_to(ROOT).parts:
            yield page.relative_to(ROOT), page.read_text()


def _defined(module: pathlib.Path, names: list[str]) -> bool:
    tree = ast.parse(module.read_text())
    scope = tree.body
    for name in names:
        found = None
        for node in scope:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.name == name:
                found = node
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                if any(isinstance(t, ast.Name) and t.id == name for t in targets):
                    found = node
            elif isinstance(node, (ast.Import, ast.ImportFrom)):
                if any((a.asname or a.name).split(".")[0] == name for a in node.names):
                    found = node
        if found is None:
            return False
        scope = getattr(found, "body", [])
    return True


#: Paths the docs may still name while they are being moved (none now); the test fails when an entry is no
#: longer needed, so the set only shrinks.
PENDING: set[str] = set()


def dotted_exists(name: str) -> bool:
    if _mapped_package(name):
        return True
    parts = name.split(".")[1:]
    for cut in range(len(parts), -1, -1):
        base = PACKAGE.joinpath(*parts[:cut])
        module = base / "__init__.py" if base.is_dir() else base.with_suffix(".py")
        if base.is_dir() and not module.is_file() and cut == len(parts):
            return True  # a folder shipped as a package (the schema's)
        if module.is_file():
            rest = parts[cut:]
            if rest and (module.parent / rest[0]).is_dir():
                return False  # a folder that is no package
            return not rest or _defined(module, rest)
    return False


def _mapped_package(name: str) -> bool:
    """A package the install maps from elsewhere in the repository (pyproject's package-dir:
    ``physomni_usd._schema`` is ``schemas/physomni``): it exists where that folder does."""
    import tomllib

    root = PACKAGE.parent
    mapped = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"].get("package-dir", {})
    return name in mapped and (root / mapped[name]).is_dir()


def inside_exists(path: str) -> bool:
    """``materials/catalog.py``, ``usd/``, or a module and a name in it: ``bench/synthetic.render_truth``."""
    path = path.rstrip("/.")
    if (PACKAGE / path).exists():
        return True
    stem, dot, attr = path.partition(".")
    return bool(dot) and (PACKAGE / f"{stem}.py").is_file() and _defined(PACKAGE / f"{stem}.py", attr.split("."))


def missing() -> list[str]:
    out = []
    for where, text in texts():
        for path in SLASHED.findall(text):
            if "*" not in path and not (ROOT / path.rstrip("/.")).exists():
                out.append(f"{where}: {path}")
        for path in INSIDE.findall(text):
            if "*" not in path and not inside_exists(path):
                out.append(f"{where}: {path}")
        for name in DOTTED.findall(text):
            if not dotted_exists(name.rstrip(".")):
                out.append(f"{where}: {name}")
    return sorted(set(out))


def test_every_path_the_docs_name_exists():
    gone = sorted(set(missing()) - PENDING)
    assert not gone, "named in the docs but not in the package:\n" + "\n".join(f"  {g}" for g in gone)


def test_pending_entries_are_still_needed():
    fixed = sorted(PENDING - set(missing()))
    assert not fixed, "fixed in the docs: remove from PENDING:\n" + "\n".join(f"  {g}" for g in fixed)


def test_the_check_sees_a_wrong_path():
    assert dotted_exists("physomni_usd.usd.contract.object_prims")
    assert dotted_exists("physomni_usd.swappable.registry.Entry.load")
    assert not dotted_exists("physomni_usd.materials.report.object_prims_gone")
    assert not dotted_exists("physomni_usd.backends.rerender")
    assert INSIDE.findall("lives in ``materials/sizes.py`` and usd/") == ["materials/sizes.py", "usd/"]
    assert inside_exists("bench/synthetic.render_truth") and not inside_exists("bench/synthetic.no_such_thing")
    assert inside_exists("bench/real/photos.json") and not inside_exists("materials/sizes.py")
    assert SLASHED.findall("see physomni_usd/usd/contract.py.") == ["physomni_usd/usd/contract.py"]
    assert not (PACKAGE / "materials/sizes.py").exists()
