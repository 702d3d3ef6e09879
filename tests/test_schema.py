"""The codeless PhysOmni schema: registered on import, applicable, and in sync with its source."""

from __future__ import annotations

import filecmp
import importlib.util
import shutil
import subprocess
import sys

import pytest
from pxr import Usd

import physomni_usd  # noqa: F401  (registers the schema)
from physomni_usd.fields import KINDS
from physomni_usd.usd.schema import API_SCHEMAS, schema_dir


@pytest.mark.parametrize("name", API_SCHEMAS)
def test_api_schema_applies_with_its_attributes(name):
    stage = Usd.Stage.CreateInMemory()
    prim = stage.DefinePrim("/X", "Xform")
    assert prim.ApplyAPI(name)
    assert any(a.GetName().startswith("physomni:") for a in prim.GetAttributes())


def test_a_field_kind_allows_the_kinds_of_the_table():
    """The schema's tokens for ``physomni:kind`` are written from ``fields.FIELD_KINDS`` by generate.py."""
    definition = Usd.SchemaRegistry().FindAppliedAPIPrimDefinition("PhysOmniForceFieldAPI")
    kind = definition.GetAttributeDefinition("physomni:kind")
    assert tuple(kind.GetMetadata("allowedTokens")) == KINDS


@pytest.mark.skipif(importlib.util.find_spec("jinja2") is None, reason="usdGenSchema needs jinja2")
def test_generated_files_match_schema_usda(tmp_path):
    src = schema_dir()
    work = tmp_path / "schemas"
    shutil.copytree(src.parent, work)
    subprocess.run([sys.executable, str(work / "generate.py")], check=True, capture_output=True)
    for name in ("generatedSchema.usda", "plugInfo.json"):
        assert filecmp.cmp(src / name, work / "physomni" / name, shallow=False), f"{name} is stale: run schemas/generate.py"
