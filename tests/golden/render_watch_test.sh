#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# golden.render_watch_redraws_each_edit (issue 61 item 4, docs/development-loop.md): `kiln watch` serves a two-variant
# pack built from a copy of the shader library, and `kiln render --watch` draws the spheres scene from its output. An
# edit of the Forward pass's fragment code (the output halved) is redrawn: the image changes; reverting the edit is
# redrawn too and gives back the first image bit for bit. Three edit-and-revert cycles, the render's open descriptors
# the same after the first and the last. Nothing here waits on time: each step reads the next status line of a process
# (watch's round line, then render's redraw line naming the archive that round published), and both processes are
# ended by SIGTERM, each with exit status 0.
#   render_watch_test.sh KILN SOURCE_DIR WORK_DIR
set -euo pipefail
kiln=$1 source=$2 work=$3
rm -rf "$work" && mkdir -p "$work/variants"
cp -r "$source/shaderlib" "$work/"
fail() { echo "FAIL: $*"; echo "--- kiln watch"; cat "$work/watch.log" "$work/watch.err" 2>/dev/null || true
         echo "--- kiln render --watch"; cat "$work/render.log" "$work/render.err" 2>/dev/null || true; exit 1; }

# One material and no scene feature: one Forward variant and one shadow caster (lavapipe makes each pipeline in
# 0.1-0.2 s).
cat > "$work/variants/tiny.pack.json" <<'JSON'
{
  "name": "tiny",
  "include_dirs": ["../shaderlib"],
  "targets": ["spirv"],
  "passes": [
    {"name": "Forward", "source": "../shaderlib/passes/LitForward.hlsl",
     "stages": {"vertex": "LitVertex", "fragment": "LitFragment"}},
    {"name": "ShadowCaster", "source": "../shaderlib/passes/ShadowCaster.hlsl",
     "stages": {"vertex": "ShadowPassVertex", "fragment": "ShadowPassFragment"}}
  ],
  "materials": [{"name": "standard", "keywords": []}],
  "scene_features": {}
}
JSON
echo '{"name": "plain", "uses": {}, "materials": ["standard"]}' > "$work/variants/plain.json"
shader="$work/shaderlib/passes/LitForward.hlsl"
original='return float4(ACESFitted(radiance), 1.0);'
edited='return float4(ACESFitted(radiance) * 0.5, 1.0);'
grep -qF "$original" "$shader" || fail "LitFragment's tone-mapped return not found in the expected form; update this test"
cp "$shader" "$work/LitForward.original.hlsl"
python3 -c 'import sys; t = open(sys.argv[1]).read(); open(sys.argv[2], "w").write(t.replace(sys.argv[3], sys.argv[4]))' \
  "$shader" "$work/LitForward.edited.hlsl" "$original" "$edited"

# Reads the process's lines from descriptor $1 (copying them to log $2) until one holds every later argument.
wait_for_line() {
  local fd=$1 log=$2; shift 2
  local line word
  while IFS= read -r -u "$fd" line; do
    printf '%s\n' "$line" >> "$log"
    for word in "$@"; do [[ $line == *"$word"* ]] || continue 2; done
    return 0
  done
  fail "the process ended before a line with: $*"
}
archive_served() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["archive"]["file"])' "$work/packs/tiny.manifest.json"; }

exec {watch_out}< <(exec "$kiln" watch "$work/variants/tiny.pack.json" --scene "$work/variants/plain.json" \
                      -o "$work/packs" --cache "$work/cache" 2> "$work/watch.err")
watch_pid=$!
wait_for_line "$watch_out" "$work/watch.log" "round 1:"
first_archive=$(archive_served)

exec {render_out}< <(exec "$kiln" render "$work/packs" --scene "$source/variants/scenes/render/spheres.json" \
                       --size 64x64 -o "$work/frame.png" --watch 2> "$work/render.err")
render_pid=$!
wait_for_line "$render_out" "$work/render.log" "watching the pack"
cp "$work/frame.png" "$work/first.png"

round=1
for cycle in 1 2 3; do
  cp "$work/LitForward.edited.hlsl" "$shader"
  round=$((round + 1))
  wait_for_line "$watch_out" "$work/watch.log" "round $round:" "LitForward.hlsl"
  archive=$(archive_served)
  [ "$archive" != "$first_archive" ] || fail "cycle $cycle: the edit published the first pack again"
  wait_for_line "$render_out" "$work/render.log" "($archive)" "Forward (none) changed" "redrew"
  cmp -s "$work/frame.png" "$work/first.png" && fail "cycle $cycle: the edited shader drew the same image"
  cp "$work/LitForward.original.hlsl" "$shader"
  round=$((round + 1))
  wait_for_line "$watch_out" "$work/watch.log" "round $round:" "LitForward.hlsl"
  archive=$(archive_served)
  [ "$archive" = "$first_archive" ] || fail "cycle $cycle: the reverted library built another pack ($archive, not $first_archive)"
  wait_for_line "$render_out" "$work/render.log" "($archive)" "redrew"
  cmp "$work/frame.png" "$work/first.png" || fail "cycle $cycle: the reverted shader's image is not the first one"
  descriptors=$(ls "/proc/$render_pid/fd" | wc -l)
  [ "$cycle" != 1 ] || first_descriptors=$descriptors
  echo "cycle $cycle: edit and revert redrawn; kiln render holds $descriptors descriptors"
done
[ "$descriptors" = "$first_descriptors" ] || fail "kiln render's descriptors grew from $first_descriptors to $descriptors"

# A damaged manifest renamed over the served one (one digit of its archive's checksum changed): refused with its
# error, and the image stays the last frame.
python3 - "$work/packs/tiny.manifest.json" <<'PY'
import os, re, sys
text = open(sys.argv[1]).read()
damaged = re.sub(r'("xxh3_64": ")(.)', lambda m: m.group(1) + ("0" if m.group(2) != "0" else "1"), text, count=1)
assert damaged != text, "no checksum in the manifest"
open(sys.argv[1] + ".damaged", "w").write(damaged)
os.rename(sys.argv[1] + ".damaged", sys.argv[1])
PY
wait_for_line "$render_out" "$work/render.log" "the new pack is refused"
grep -q "error\[K2004\]" "$work/render.err" || fail "the refused pack's error is not printed"
cmp "$work/frame.png" "$work/first.png" || fail "a refused pack changed the image"

kill -TERM "$render_pid" "$watch_pid"
status=0; wait "$render_pid" || status=$?
[ "$status" = 0 ] || fail "kiln render --watch ended by SIGTERM with $status"
status=0; wait "$watch_pid" || status=$?
[ "$status" = 0 ] || fail "kiln watch ended by SIGTERM with $status"
wait_for_line "$render_out" "$work/render.log" "stopped"
cat "$work/render.log"
echo "PASS: kiln render --watch redrew $((round - 1)) edits; each revert gave back the first image"
