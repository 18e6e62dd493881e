#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# golden.broken_shader_fails: proves the golden suite catches a wrong shader. A copy of the shader library
# gets a sign error in F_Schlick (the real3 version DirectBRDF calls); the pack built from it must fail
# kiln test against the CPU reference images golden.setup made for the default pack (these variants are a
# subset of it), on Vulkan and on OpenGL ES; the unmodified library passes the same variants in
# golden.*.spheres. The error changes Fresnel only where LoH is small, so the variants whose images show grazing
# half vectors fail (the ones with the additional lights); the suite as a whole must fail, and at least a
# third of the variants. Then a pack whose GL records swap two texture bindings must be refused by the GL
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

# The same broken pack through its GLSL ES output on llvmpipe, on its pairwise covering sample.
if "$kiln" test "$work/broken" --api gles --cover 2 --scene "$scene" --golden "$goldens" --tolerances "$tolerances" \
     > "$work/broken-gles.log"; then
  cat "$work/broken-gles.log"; echo "broken_shader_test: a sign error in F_Schlick passed the GLSL ES golden suite"; exit 1
fi
echo "broken F_Schlick, GLSL ES: $(grep -c '^FAIL' "$work/broken-gles.log" || true) variants failed"

# Swapped GL bindings in the pack's records: the texture units the records give no longer match the program. The
# renderer reads the records a game reads, the archive's runtime index, so the edit is made there: each GL
# combined-sampler record is <name> <texture> <sampler> u32 binding (each string a u32 length, its bytes and a NUL;
# compiler/include/kiln/runtime_index.hpp), and in each record list "_DFG_..." comes right before
# "_EnvironmentMap_...". The pack is then resealed by the rules of compiler/include/kiln/pack_format.hpp (the head's
# and the whole archive's XXH3-64 in the header, the archive named by its XXH3-64, the manifest's record of it and its
# own checksum), with xxHash's own library.
cp -r "$work/broken" "$work/swapped"
python3 - "$work/swapped" <<'PY'
import ctypes, glob, os, re, struct, sys
xxh = ctypes.CDLL("libxxhash.so.0")
xxh.XXH3_64bits.restype = ctypes.c_uint64
xxh.XXH3_64bits.argtypes = (ctypes.c_char_p, ctypes.c_size_t)
h = lambda b: xxh.XXH3_64bits(bytes(b), len(b))
path = glob.glob(sys.argv[1] + "/*.manifest.json")[0]
text = open(path, "rb").read()
old_file = re.search(rb'"file": "([^"]+\.kpack)"', text).group(1).decode()
archive = bytearray(open(os.path.join(sys.argv[1], old_file), "rb").read())
index_end = struct.unpack_from("<Q", archive, 32)[0] + struct.unpack_from("<Q", archive, 40)[0]
def records(texture):
    t = texture.encode()
    pattern = re.escape(t) + rb"_([A-Za-z0-9_]+)\x00" + re.escape(struct.pack("<I", len(t)) + t + b"\x00") + rb"....\1\x00"
    return [(m.start(), m.end()) for m in re.finditer(pattern, bytes(archive[:index_end]), re.S)]
dfg, env = records("_DFG"), records("_EnvironmentMap")
swapped = 0
for start, end in dfg:
    after = [e for e in env if e[0] > end]
    if not after: continue
    other = after[0][1]
    a, b = archive[end:end + 4], archive[other:other + 4]
    archive[end:end + 4], archive[other:other + 4] = b, a
    swapped += 1
assert swapped, "no GL record list holds both _DFG and _EnvironmentMap"
struct.pack_into("<Q", archive, 48, h(archive[64:index_end]))
struct.pack_into("<Q", archive, 16, h(archive[64:]))
digest = "%016x" % h(archive)
new_file = re.sub(r"\.[0-9a-f]{16}\.kpack$", "." + digest + ".kpack", old_file)
os.remove(os.path.join(sys.argv[1], old_file))
open(os.path.join(sys.argv[1], new_file), "wb").write(archive)
text = text.replace(old_file.encode(), new_file.encode())
text = re.sub(rb'"xxh3_64": "[0-9a-f]{16}"', b'"xxh3_64": "' + digest.encode() + b'"', text, count=1)
key = b'"manifest_xxh3_64": "'
at = text.index(key) + len(key)
text = text[:at] + b"0" * 16 + text[at + 16:]
text = text[:at] + b"%016x" % h(text) + text[at + 16:]
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
