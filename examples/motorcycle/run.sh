#!/usr/bin/env bash
# Usage: bash examples/motorcycle/run.sh [OUT_DIR]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="${1:-out/motorcycle}"
physomni-usd run "$here/photo.png" -o "$out" \
    --mask "$here/motorcycle.png" --mask "$here/bench.png" --mask "$here/bin.png" \
    --push motorcycle=0,0.8,0 --seconds 3
