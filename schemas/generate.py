"""Regenerate the codeless PhysOmni schema files from ``physomni/schema.usda``.

Run from anywhere: ``python schemas/generate.py``. It calls OpenUSD's own
``usdGenSchema`` (shipped with usd-core, needs jinja2) and writes
``generatedSchema.usda`` and ``plugInfo.json`` beside ``schema.usda``.
Both outputs are committed and shipped in the wheel.
"""

import pathlib
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


def main() -> int:
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
