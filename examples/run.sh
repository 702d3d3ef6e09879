#!/usr/bin/env bash
# Usage: bash examples/run.sh EXAMPLE_DIR [OUT_DIR]
# Runs `physomni-usd run` on an example folder as its example.json describes it
# (photo, masks or boxes with labels, sizes, pushes, seconds if it gives them), writing to OUT_DIR
# (default out/<example>).
set -euo pipefail
dir="$(cd "$1" && pwd)"
out="${2:-out/$(basename "$dir")}"
mapfile -t args < <(python3 - "$dir" <<'PY'
import json, pathlib, sys

folder = pathlib.Path(sys.argv[1])
spec = json.loads((folder / "example.json").read_text())
print(folder / spec["photo"])
for mask in spec.get("masks", []):
    print("--mask")
    print(folder / mask)
for box in spec.get("boxes", []):
    print("--box")
    print(box)
for size in spec.get("size", []):
    print("--size")
    print(size)
for push in spec.get("push", []):
    print("--push")
    print(push)
if "seconds" in spec:  # else run's own length: 3 s, ended once nothing has moved for a second
    print("--seconds")
    print(spec["seconds"])
PY
)
physomni-usd run "${args[@]}" -o "$out"
