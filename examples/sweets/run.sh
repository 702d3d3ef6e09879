#!/usr/bin/env bash
# Usage: bash examples/sweets/run.sh [OUT_DIR] — what example.json beside this file describes.
here="$(dirname "${BASH_SOURCE[0]}")"
exec bash "$here/../run.sh" "$here" "${1:-out/sweets}"
