#!/usr/bin/env bash
# Writes the fuzzers' seed corpora (tests/fuzz/corpus/<target>/) from kiln's own outputs and files:
#   pack_reader:  real packs kiln builds from a tiny shader (all targets; SPIR-V only), in the harness's input
#                 format (flags byte 0, manifest length, manifest, archive);
#   declarations: shader library passes, each with one library file as its include file.
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
mkdir -p "$corpus/pack_reader" "$corpus/declarations"
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
