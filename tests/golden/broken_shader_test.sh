#!/usr/bin/env bash
# golden.broken_shader_fails: proves the golden suite catches a wrong shader. A copy of the shader library
# gets a sign error in F_Schlick (the real3 version DirectBRDF calls); the pack built from it must fail
# kiln test against the CPU reference images golden.setup made for the default pack (these variants are a
# subset of it), on Vulkan and on OpenGL ES; the unmodified library passes the same variants in
# golden.*.spheres. The error changes Fresnel only where LoH is small, so the variants whose images show grazing
# half vectors fail (the ones with the additional lights); the suite as a whole must fail, and at least a
# third of the variants. Then a manifest whose GL records swap two texture bindings must be refused by the GL
# renderer (the records are checked against the linked program), so a pack and its records cannot drift.
#   broken_shader_test.sh KILN SOURCE_DIR WORK_DIR GOLDEN_WORK_DIR (golden.setup's)
set -euo pipefail
kiln=$1 source=$2 work=$3 goldens=$4/goldens/spheres
rm -rf "$work" && mkdir -p "$work"
cp -r "$source/shaderlib" "$source/variants" "$work/"
# The outdoor_day scene profile keeps a few dozen Forward variants: enough to exercise the lobe everywhere.
profile="$work/variants/scenes/outdoor_day.json"
grep -q 'return f0 + (f90 - f0) \* f;' "$work/shaderlib/BRDF.hlsl" || {
  echo "broken_shader_test: F_Schlick not found in the expected form; update this test"; exit 1; }
sed -i 's/return f0 + (f90 - f0) \* f;/return f0 - (f90 - f0) * f;/' "$work/shaderlib/BRDF.hlsl"
"$kiln" build "$work/variants/lit.pack.json" --scene "$profile" -o "$work/broken" --cache "$work/cache" -q
scene="$source/variants/scenes/render/spheres.json"
tolerances="$source/variants/scenes/render/tolerances.json"
if "$kiln" test "$work/broken" --scene "$scene" --golden "$goldens" --tolerances "$tolerances" \
     --report "$work/report" > "$work/broken.log"; then
  cat "$work/broken.log"; echo "broken_shader_test: a sign error in F_Schlick passed the golden suite"; exit 1
fi
passed=$(grep -c '^PASS' "$work/broken.log" || true)
failed=$(grep -c '^FAIL' "$work/broken.log" || true)
echo "broken F_Schlick: $failed variants failed, $passed passed"
test -f "$work/report/index.html" || { echo "broken_shader_test: no HTML report written"; exit 1; }
[ "$failed" -ge $(( (passed + failed) / 3 )) ] || { echo "broken_shader_test: too few variants caught the error"; exit 1; }

# The same broken pack through its GLSL ES output on llvmpipe.
if "$kiln" test "$work/broken" --api gles --scene "$scene" --golden "$goldens" --tolerances "$tolerances" \
     > "$work/broken-gles.log"; then
  cat "$work/broken-gles.log"; echo "broken_shader_test: a sign error in F_Schlick passed the GLSL ES golden suite"; exit 1
fi
echo "broken F_Schlick, GLSL ES: $(grep -c '^FAIL' "$work/broken-gles.log" || true) variants failed"

# Swapped GL bindings in the manifest: the texture units the records give no longer match the program.
cp -r "$work/broken" "$work/swapped"
python3 - "$work/swapped" <<'PY'
import glob, json, sys
path = glob.glob(sys.argv[1] + "/*.manifest.json")[0]
manifest = json.load(open(path))
swapped = 0
for reflection in manifest["reflections"]:
    for api in ("glsl", "gles"):
        records = {r["texture"]: r for r in reflection.get(api, {}).get("combined_image_samplers", [])}
        if "_DFG" in records and "_EnvironmentMap" in records:
            a, b = records["_DFG"], records["_EnvironmentMap"]
            a["binding"], b["binding"] = b["binding"], a["binding"]
            swapped += 1
assert swapped, "no stage samples both _DFG and _EnvironmentMap"
# Reseal the edited manifest (its own checksum, the rule of compiler/include/kiln/pack_format.hpp: XXH3-64
# of the file with the 16 digits of "manifest_xxh3_64" zeroed), so that the reader takes it and the edit
# reaches the GL binding check; xxHash's own library computes the hash.
import ctypes
xxh = ctypes.CDLL("libxxhash.so.0")
xxh.XXH3_64bits.restype = ctypes.c_uint64
xxh.XXH3_64bits.argtypes = (ctypes.c_char_p, ctypes.c_size_t)
manifest["manifest_xxh3_64"] = "0" * 16
text = json.dumps(manifest).encode()
key = b'"manifest_xxh3_64": "'
at = text.index(key) + len(key)
text = text[:at] + b"%016x" % xxh.XXH3_64bits(text, len(text)) + text[at + 16:]
open(path, "wb").write(text)
PY
for api in gl gles; do
  if "$kiln" render "$work/swapped" --api $api --scene "$scene" --variant "" -o "$work/swapped.png" 2> "$work/swapped.err"; then
    echo "broken_shader_test: $api rendered with swapped binding records"; exit 1
  fi
  grep -q "the manifest records binding .* but the GL driver reports" "$work/swapped.err" || {
    cat "$work/swapped.err"; echo "broken_shader_test: wrong diagnostic for swapped GL bindings"; exit 1; }
  echo "swapped GL bindings ($api): $(cat "$work/swapped.err")"
done
