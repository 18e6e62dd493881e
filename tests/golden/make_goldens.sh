#!/usr/bin/env bash
# golden.setup: builds the default pack and the debug pack, then has the CPU reference shade the reference
# image of every Forward variant from the G-buffer and shadow maps lavapipe rendered; the same for the stress
# scene (night_city) and the pack its scene profile strips.
#   make_goldens.sh KILN KILN_REFERENCE SOURCE_DIR WORK_DIR
set -euo pipefail
kiln=$1 reference=$2 source=$3 work=$4
mkdir -p "$work"
"$kiln" build "$source/variants/lit.pack.json" -o "$work/packs/lit" --cache "$work/cache" -q
"$kiln" build "$source/variants/debug.pack.json" -o "$work/packs/debug" --cache "$work/cache" -q
"$reference" goldens --pack "$work/packs/lit" --debug-pack "$work/packs/debug" \
  --scene "$source/variants/scenes/render/spheres.json" -o "$work/goldens/spheres"
# The stress scene (256 point lights and two shadowed lights) with the variants of its scene profile.
"$kiln" build "$source/variants/lit.pack.json" --scene "$source/variants/scenes/night_city.json" \
  -o "$work/packs/night_city" --cache "$work/cache" -q
"$reference" goldens --pack "$work/packs/night_city" --debug-pack "$work/packs/debug" \
  --scene "$source/variants/scenes/render/night_city.json" -o "$work/goldens/night_city"
