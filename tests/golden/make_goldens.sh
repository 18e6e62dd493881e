#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# golden.setup and golden.setup.<scene>, in two steps so that ctest can run the reference shading of the two
# scenes beside each other and beside the tests that need only the packs:
#   make_goldens.sh KILN KILN_REFERENCE SOURCE_DIR WORK_DIR packs
#       builds the default pack, its specialized twin, the debug pack (its GBuffer pass is checked against the
#       reference's geometry)
#       and the packs the night_city and audit scene profiles strip
#   make_goldens.sh KILN KILN_REFERENCE SOURCE_DIR WORK_DIR spheres|night_city|audit
#       has the CPU reference shade the reference image of every Forward variant of the scene's pack (those the
#       scene judges) from its own rasterization of the scene and of its shadow maps
set -euo pipefail
kiln=$1 reference=$2 source=$3 work=$4 step=$5
mkdir -p "$work"
case "$step" in
  packs)
    "$kiln" build "$source/variants/lit.pack.json" -o "$work/packs/lit" --cache "$work/cache" -q
    "$kiln" build "$source/variants/debug.pack.json" -o "$work/packs/debug" --cache "$work/cache" -q
    # The same variants with soft shadows, fog and multiscatter folded into specialization constants: judged
    # against the default pack's reference images (the reference knows no kinds).
    "$kiln" build "$source/variants/lit_specialized.pack.json" -o "$work/packs/lit_specialized" --cache "$work/cache" -q
    # The stress scene (256 point lights and two shadowed lights) with the variants of its scene profile.
    "$kiln" build "$source/variants/lit.pack.json" --scene "$source/variants/scenes/night_city.json" \
      -o "$work/packs/night_city" --cache "$work/cache" -q
    # The adversarial scene (backlit, rotated and non-uniformly scaled objects, full Forward+ tiles) with the
    # variants of its scene profile.
    "$kiln" build "$source/variants/lit.pack.json" --scene "$source/variants/scenes/audit.json" \
      -o "$work/packs/audit" --cache "$work/cache" -q ;;
  spheres)
    "$reference" goldens --pack "$work/packs/lit" \
      --scene "$source/variants/scenes/render/spheres.json" -o "$work/goldens/spheres" ;;
  night_city)
    "$reference" goldens --pack "$work/packs/night_city" \
      --scene "$source/variants/scenes/render/night_city.json" -o "$work/goldens/night_city" ;;
  audit)
    "$reference" goldens --pack "$work/packs/audit" \
      --scene "$source/variants/scenes/render/audit.json" -o "$work/goldens/audit" ;;
  *) echo "make_goldens.sh: unknown step '$step' (packs, spheres, night_city or audit)"; exit 2 ;;
esac
