#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# golden.determinism and golden.cross_variant: the same variant renders bit-identical images twice (on each
# API), and variants that must look the same do (Forward+ vs the plain light loop, fog with zero density vs no
# fog, main-light shadows with nothing to occlude vs no shadows). Also: GALLIVM_PERF=nopt, which the golden
# tests set to halve llvmpipe's JIT time, changes no bit of an image (LLVM's IR passes keep IEEE results). And
# each keyword acts: shadows darken, fog blends, Forward+ shades only the lights its tile lists name.
#   determinism_test.sh KILN SOURCE_DIR WORK_DIR (WORK_DIR/packs/lit from golden.setup)
set -euo pipefail
kiln=$1 source=$2 work=$3
out="$work/cross" && rm -rf "$out" && mkdir -p "$out"
pack="$work/packs/lit" scene="$source/variants/scenes/render/spheres.json"
# One process per image: the PNG and the float image in kiln's raw format (.kimg, read below without an EXR
# library).
render() {  # NAME SCENE VARIANT [API]
  "$kiln" render "$pack" --api "${4:-vulkan}" --scene "$2" --variant "$3" -o "$out/$1.png" --exr "$out/$1.kimg" > /dev/null
}
# Bit-identical PNG and float image.
same() {
  if cmp -s "$out/$1.png" "$out/$2.png" && cmp -s "$out/$1.kimg" "$out/$2.kimg"; then echo "same: $1 = $2"
  else echo "DIFFERENT: $1 vs $2 ($3)"; exit 1; fi
}
# Equal up to fp32 rounding: two different shaders may contract or order the same arithmetic differently.
close() {
  python3 - "$out/$1.kimg" "$out/$2.kimg" "$3" <<'PY'
import array, sys
def load(path):
    data = open(path, "rb").read()
    assert data[:4] == b"KIMG"
    pixels = array.array("f"); pixels.frombytes(data[16:])
    return pixels
a, b = load(sys.argv[1]), load(sys.argv[2])
worst = max(abs(x - y) / max(1.0, abs(y)) for x, y in zip(a, b))
print(("close" if worst <= 1e-5 else "DIFFERENT") + f": {sys.argv[1]} vs {sys.argv[2]}: max relative difference {worst:.2e} (limit 1e-5)")
sys.exit(0 if worst <= 1e-5 else f"{sys.argv[3]}")
PY
}
variant="_MAIN_LIGHT_SHADOWS_CASCADE _SHADOWS_SOFT _ADDITIONAL_LIGHTS _ADDITIONAL_LIGHT_SHADOWS FOG_EXP2 _MULTISCATTER"
# The OpenEXR output of one variant, written twice, is byte-identical too.
for run in a b; do
  "$kiln" render "$pack" --scene "$scene" --variant "$variant" -o "$out/exr_$run.png" --exr "$out/exr_$run.exr" > /dev/null
done
cmp -s "$out/exr_a.exr" "$out/exr_b.exr" && echo "same: exr_a.exr = exr_b.exr" ||
  { echo "DIFFERENT: exr_a.exr vs exr_b.exr (one variant's OpenEXR output must be bit-identical)"; exit 1; }
[ "$(head -c 4 "$out/exr_a.exr" | od -An -tx1 | tr -d ' ')" = 762f3101 ] || { echo "not an OpenEXR file: exr_a.exr"; exit 1; }
for api in vulkan gl gles; do
  render twice_a_$api "$scene" "$variant" $api
  render twice_b_$api "$scene" "$variant" $api
  same twice_a_$api twice_b_$api "one variant rendered twice must be bit-identical ($api)"
  # Both compiled now (no Mesa shader cache, whose key may not include the flag), with and without IR passes.
  MESA_SHADER_CACHE_DISABLE=true GALLIVM_PERF=nopt render unoptimized_$api "$scene" "$variant" $api
  MESA_SHADER_CACHE_DISABLE=true GALLIVM_PERF= render optimized_$api "$scene" "$variant" $api
  same unoptimized_$api optimized_$api "GALLIVM_PERF=nopt must not change the image ($api)"
done

# Forward+ lists every light that can reach a tile, in index order; the others add exactly 0.
render plain "$scene" "_ADDITIONAL_LIGHTS _ADDITIONAL_LIGHT_SHADOWS"
render tiled "$scene" "_ADDITIONAL_LIGHTS _ADDITIONAL_LIGHT_SHADOWS _FORWARD_PLUS"
same plain tiled "Forward+ must shade like the plain loop over the same lights"

# A is darker than B on average over RGB by at least FRACTION (the keyword under test does something).
darker() {
  python3 - "$out/$1.kimg" "$out/$2.kimg" "$3" "$4" <<'PY'
import array, sys
def mean(path):
    data = open(path, "rb").read()
    pixels = array.array("f"); pixels.frombytes(data[16:])
    rgb = [v for i, v in enumerate(pixels) if i % 4 != 3]
    return sum(rgb) / len(rgb)
a, b, fraction = mean(sys.argv[1]), mean(sys.argv[2]), float(sys.argv[3])
ok = a < b * (1 - fraction)
print(("darker" if ok else "NOT DARKER") + f": {sys.argv[1]} mean {a:.5f} vs {sys.argv[2]} mean {b:.5f} (by at least {fraction:.1%})")
sys.exit(0 if ok else sys.argv[4])
PY
}

# Writes a copy of the scene with absolute data paths, edited by a Python statement on `r` (its "render").
derive() {
  python3 - "$scene" "$out/$1.json" "$2" <<'PY'
import json, os, sys
scene = json.load(open(sys.argv[1]))
base = os.path.dirname(os.path.abspath(sys.argv[1]))
r = scene["render"]
r["environment"]["file"] = os.path.join(base, r["environment"]["file"])
r["environment"]["dfg"] = os.path.join(base, r["environment"]["dfg"])
exec(sys.argv[3])
json.dump(scene, open(sys.argv[2], "w"))
PY
}

# Fog of zero density: the factor is exactly 1.
derive nofog_density 'r["fog"]["density"] = 0.0'
render fog_none "$out/nofog_density.json" ""
render fog_exp_zero "$out/nofog_density.json" "FOG_EXP"
render fog_exp2_zero "$out/nofog_density.json" "FOG_EXP2"
same fog_none fog_exp_zero "FOG_EXP with density 0 must match no fog"
same fog_none fog_exp2_zero "FOG_EXP2 with density 0 must match no fog"

# Shadows with nothing to occlude: only the ground plane, which cannot shadow itself.
derive unoccluded 'r["objects"] = [o for o in r["objects"] if o.get("shape") == "plane"]'
render unshadowed "$out/unoccluded.json" ""
render shadowed "$out/unoccluded.json" "_MAIN_LIGHT_SHADOWS"
render shadowed_cascades "$out/unoccluded.json" "_MAIN_LIGHT_SHADOWS_CASCADE _SHADOWS_SOFT"
close unshadowed shadowed "hard shadows from an unoccluded light must match no shadows"
close unshadowed shadowed_cascades "soft cascaded shadows from an unoccluded light must match no shadows"

# Each keyword acts: shadows darken, fog blends towards its (dark) color here, Forward+ reads its tile lists.
render lit_only "$scene" ""
render sun_shadows "$scene" "_MAIN_LIGHT_SHADOWS"
darker sun_shadows lit_only 0.02 "main-light shadows must darken the image"
render point_lights "$scene" "_ADDITIONAL_LIGHTS"
render point_shadows "$scene" "_ADDITIONAL_LIGHTS _ADDITIONAL_LIGHT_SHADOWS"
darker point_shadows point_lights 0.002 "additional-light shadows must darken the image"
derive dark_fog 'r["fog"]["color"] = [0.0, 0.0, 0.0]'
render dark_fog_none "$out/dark_fog.json" ""
render dark_fog_exp2 "$out/dark_fog.json" "FOG_EXP2"
darker dark_fog_exp2 dark_fog_none 0.02 "black fog must darken the image"
derive short_bins 'r["tile_binning_range_scale"] = 0.05'
render short_bins_plain "$out/short_bins.json" "_ADDITIONAL_LIGHTS"
render short_bins_tiled "$out/short_bins.json" "_ADDITIONAL_LIGHTS _FORWARD_PLUS"
darker short_bins_tiled short_bins_plain 0.002 "Forward+ must shade only the lights of its tile lists"
