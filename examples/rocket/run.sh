#!/usr/bin/env bash
# Usage: bash examples/rocket/run.sh [OUT_DIR]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="${1:-out/rocket}"
physomni-usd run "$here/photo.png" -o "$out" \
    --mask "$here/rocket.png" --mask "$here/tower_left.png" --mask "$here/tower_right.png" \
    --push rocket=0,0.6,0 --seconds 3
