#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Writes the fuzzers' seed corpora (tests/fuzz/corpus/<target>/) from kiln's own outputs and files:
#   pack_reader:  real packs kiln builds from a tiny shader (all targets; SPIR-V only), in the harness's input
#                 format (flags byte 0, manifest length, manifest, archive);
#   declarations: shader library passes, each with one library file as its include file;
#   coverage_map: the SPIR-V modules of a -g --coverage build of the same shader (the stages of each variant);
#   endpoint:     request bodies of kiln watch --serve, as the development reader sends them (a variant asked for,
#                 a report of what it selected) and at the edges of the protocol's bounds.
# The rest of each corpus (files named by their SHA-1) is what fuzzing kept, reduced to one input per
# coverage edge: <fuzzer> -merge=1 -use_counters=0 <empty dir> <corpus> <fuzzer's output dirs>. After a pack
# format change, delete the pack_reader ones (they would stop at the version check), run this script, fuzz,
# and merge again.
# usage: make_seeds.sh <kiln> <kiln source dir>
set -euo pipefail
kiln=$1 source=$2
corpus="$source/tests/fuzz/corpus"
work=$(mktemp -d /tmp/kiln-seeds-XXXXXX)
trap 'rm -rf "$work"' EXIT

cat > "$work/S.hlsl" <<'HLSL'
#pragma multi_compile_fragment _ FOG
#pragma shader_feature_local _ TINT
cbuffer PerDraw : register(b2) { float4 _Tint; };
Texture2D _MainTex : register(t0);
SamplerState _Sampler : register(s1);
struct Interpolants { float4 position : SV_Position; float2 uv : TEXCOORD0; };
Interpolants V(float4 p : POSITION) { Interpolants o; o.position = p; o.uv = p.xy; return o; }
float4 F(Interpolants i) : SV_Target {
  float4 c = _MainTex.Sample(_Sampler, i.uv);
#ifdef TINT
  c *= _Tint;
#endif
#ifdef FOG
  c.rgb = lerp(c.rgb, float3(0.5, 0.5, 0.5), exp2(-i.position.z));
#endif
  c.a *= _Tint.a;
  return c;
}
HLSL
echo '{"name": "tiny", "passes": [{"name": "Forward", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]}' \
  > "$work/tiny.pack.json"
echo '{"name": "spv", "targets": ["spirv"], "passes": [{"name": "Forward", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]}' \
  > "$work/spv.pack.json"
mkdir -p "$corpus/pack_reader" "$corpus/declarations" "$corpus/coverage_map"
for pack in tiny spv; do
  "$kiln" build "$work/$pack.pack.json" -o "$work/out" --no-cache -q
  python3 - "$work/out/$pack.manifest.json" "$corpus/pack_reader/$pack-pack" <<'PY'
import json, os, struct, sys
manifest = open(sys.argv[1], "rb").read()
archive = open(os.path.join(os.path.dirname(sys.argv[1]), json.loads(manifest)["archive"]["file"]), "rb").read()
open(sys.argv[2], "wb").write(bytes([0]) + struct.pack("<I", len(manifest)) + manifest + archive)
PY
done

split=$'\n//--include--\n'
for pair in passes/DepthOnly.hlsl:Common.hlsl passes/ShadowCaster.hlsl:Shadows.hlsl passes/DepthNormals.hlsl:Input.hlsl \
            passes/DebugGBuffer.hlsl:Fog.hlsl; do
  entry=${pair%%:*} include=${pair##*:}
  # The entry includes the include file under the name the harness gives it.
  { printf '#include "Inc.hlsl"\n'; cat "$source/shaderlib/$entry"; printf '%s' "$split"; cat "$source/shaderlib/$include"; } \
    > "$corpus/declarations/$(basename "$entry" .hlsl)"
done

echo '{"name": "cov", "targets": ["spirv"], "passes": [{"name": "Forward", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]}' \
  > "$work/cov.pack.json"
"$kiln" build "$work/cov.pack.json" -o "$work/cov" -g --coverage --no-cache -q
# The archive's blob table (kiln/pack_format.hpp): offset, stored size, raw size per blob; a stored size below the
# raw size is a zstd frame. Each SPIR-V module is a seed, named by what it is.
python3 - "$work/cov/cov.manifest.json" "$corpus/coverage_map" <<'PY'
import ctypes, json, os, struct, sys
# libzstd itself (kiln's own dependency), not the zstd program, which the machines need not have.
zstd = ctypes.CDLL("libzstd.so.1")
zstd.ZSTD_decompress.restype = ctypes.c_size_t
zstd.ZSTD_decompress.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_char_p, ctypes.c_size_t]
manifest = json.load(open(sys.argv[1]))
archive = open(os.path.join(os.path.dirname(sys.argv[1]), manifest["archive"]["file"]), "rb").read()
for n, binary in enumerate(manifest["binaries"]):
    offset, stored, raw = struct.unpack_from("<QQQ", archive, 64 + 32 * binary["blobs"]["spirv"])
    blob = archive[offset:offset + stored]
    if stored < raw:
        out = ctypes.create_string_buffer(raw)
        assert zstd.ZSTD_decompress(out, raw, blob, stored) == raw
        blob = out.raw
    open(os.path.join(sys.argv[2], "cov-%s-%d" % (binary["stage"], n)), "wb").write(blob)
PY
# And two hand-made modules (as unit.Coverage.* makes them): a block of 50 lines and 50 stores, and a small one that
# ends in an OpString of one word (the reader once read 2^32 words from there, past the module).
python3 - "$corpus/coverage_map" <<'PY'
import os, struct, sys
def text(s):
    b = s.encode() + b"\0"
    b += b"\0" * (-len(b) % 4)
    return list(struct.unpack("<%dI" % (len(b) // 4), b))
def op(code, count): return (count << 16) | code
def module(lines, stores, tail):
    m = [0x07230203, 0x10000, 0, 100, 0]
    f, n = text("f.hlsl"), text("_KilnCoverage")
    m += [op(7, 2 + len(f)), 1] + f + [op(5, 2 + len(n)), 2] + n
    m += [op(71, 4), 2, 34, 0, op(71, 4), 2, 33, 63, op(43, 4), 9, 3, 8, op(54, 5), 9, 4, 0, 9, op(248, 2), 5]
    for l in range(lines): m += [op(8, 4), 1, l + 1, 1]
    m += [op(65, 5), 9, 6, 2, 3]
    for s in range(stores): m += [op(62, 3), 6, 3]
    m += tail
    return struct.pack("<%dI" % len(m), *m)
open(os.path.join(sys.argv[1], "block-of-50-lines-and-50-stores"), "wb").write(module(50, 50, []))
open(os.path.join(sys.argv[1], "opstring-of-one-word"), "wb").write(module(2, 1, [op(7, 1)]))
PY

# The development endpoint's bodies (docs/development-loop.md, "Protocol, version 1").
mkdir -p "$corpus/endpoint"
python3 - "$corpus/endpoint" <<'PY'
import json, os, sys
def seed(name, body):
    open(os.path.join(sys.argv[1], name), "w").write(body if isinstance(body, str) else json.dumps(body))
seed("variant", {"pass": "Forward", "keywords": ["_FOG", "_SHADOWS_SOFT"]})
seed("variant-without-keywords", {"pass": "ShadowCaster"})
seed("variant-64-keywords-unsorted", {"pass": "P", "keywords": ["K%d" % (63 - i) for i in range(64)] + ["K0"]})
seed("report", {"client": "4242-0123456789abcdef", "selected": [{"pass": "Forward", "keywords": ["_FOG"]},
                                                              {"pass": "DepthOnly", "keywords": []}]})
seed("report-256-variants", {"client": "c", "selected": [{"pass": "P", "keywords": ["K%d" % i]} for i in range(256)]})
seed("report-deep", '{"client": "c", "selected": [{"pass": "P", "keywords": [["A"]]}]}')
PY
