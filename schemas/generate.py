"""Regenerate the codeless PhysOmni schema files from ``physomni/schema.usda``.

Run from anywhere: ``python schemas/generate.py``. It first writes the force
field kinds of ``physomni_usd.fields.FIELD_KINDS`` into ``schema.usda``'s
``allowedTokens`` for ``physomni:kind`` (the kinds are listed once, in that
table), then calls OpenUSD's own ``usdGenSchema`` (shipped with usd-core, needs
jinja2), which writes ``generatedSchema.usda`` and ``plugInfo.json`` beside
``schema.usda``. Both outputs are committed and shipped in the wheel.
"""

import json
import pathlib
import re
import subprocess
import sys

HERE = pathlib.Path(__file__).resolve().parent / "physomni"


# usdGenSchema leaves CMake placeholders in plugInfo.json; a resource-only
# plugin registered from its own folder resolves everything relative to it.
PLACEHOLDERS = {
    "@PLUG_INFO_ROOT@": ".",
    "@PLUG_INFO_RESOURCE_PATH@": ".",
    "@PLUG_INFO_LIBRARY_PATH@": "",
}


#: The allowed tokens of a field's kind in schema.usda.
KIND_TOKENS = re.compile(r'(token physomni:kind = "\w+" \(\s*allowedTokens = )\[[^\]]*\]')


def write_kinds(schema: pathlib.Path) -> None:
    from physomni_usd.fields import KINDS

    text = schema.read_text()
    new, found = KIND_TOKENS.subn(lambda m: m.group(1) + json.dumps(list(KINDS)), text)
    if found != 1:
        raise SystemExit(f"{schema}: no allowedTokens of physomni:kind to write the kinds into")
    if new != text:
        schema.write_text(new)


def main() -> int:
    write_kinds(HERE / "schema.usda")
    cmd = [sys.executable, "-m", "pxr.Usd.usdGenSchema", str(HERE / "schema.usda"), str(HERE)]
    code = subprocess.call(cmd)
    if code:
        return code
    info = HERE / "plugInfo.json"
    text = info.read_text()
    for key, value in PLACEHOLDERS.items():
        text = text.replace(key, value)
    info.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
