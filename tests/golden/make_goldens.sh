#!/usr/bin/env bash
# golden.setup: builds the default pack and the debug pack, then has the CPU reference shade the reference
# image of every Forward variant from the G-buffer and shadow maps lavapipe rendered.
#   make_goldens.sh KILN KILN_REFERENCE SOURCE_DIR WORK_DIR
set -euo pipefail
kiln=$1 reference=$2 source=$3 work=$4
mkdir -p "$work"
"$kiln" build "$source/variants/lit.pack.json" -o "$work/packs/lit" --cache "$work/cache" -q
"$kiln" build "$source/variants/debug.pack.json" -o "$work/packs/debug" --cache "$work/cache" -q
"$reference" goldens --pack "$work/packs/lit" --debug-pack "$work/packs/debug" \
  --scene "$source/variants/scenes/render/spheres.json" -o "$work/goldens/spheres"
