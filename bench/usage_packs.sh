#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Default, scene-stripped and usage-stripped packs of the bundled library for one recorded run (issue 42 item 6,
# bench/REPORT.md "Usage recording"): the adversarial scene (variants/scenes/render/audit.json) is rendered on lavapipe
# over the default pack and records its usage log as a game would (kiln test --usage-log); then the default pack, the
# pack of the scene's own profile (variants/scenes/audit.json) and the pack of that log are each built cold (no
# cache), in 3 interleaved rounds, and their variants, build times and sizes are printed side by side.
#
#   bench/usage_packs.sh BUILD_DIR     (needs BUILD_DIR/tests/golden-work from `ctest -L golden`: the default pack and
#                                       the audit scene's reference images; writes bench/results/usage_packs-<date>.txt)
set -euo pipefail
source_dir=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "$1" && pwd)
kiln=$build/compiler/kiln
golden=$build/tests/golden-work
work=$(mktemp -d /tmp/kiln-usage-packs-XXXXXX)
trap 'rm -rf "$work"' EXIT
out="$source_dir/bench/results/usage_packs-$(date +%Y-%m-%d).txt"
exec > >(tee "$out") 2>&1
echo "# $(date -u +%FT%TZ) $(uname -n), $(nproc) cores; kiln $(git -C "$source_dir" rev-parse --short HEAD)"

"$kiln" test "$golden/packs/lit" --scene "$source_dir/variants/scenes/render/audit.json" --golden "$golden/goldens/audit" \
  --tolerances "$source_dir/variants/scenes/render/tolerances.json" --usage-log "$work/audit-run.json" | tail -2

declare -A extra=([default]="" [scene]="--scene $source_dir/variants/scenes/audit.json" [usage]="--usage $work/audit-run.json")
for round in 1 2 3; do
  for kind in default scene usage; do
    rm -rf "${work:?}/$kind"
    start=$(date +%s.%N)
    # shellcheck disable=SC2086 # extra holds whole options
    "$kiln" build "$source_dir/variants/lit.pack.json" -o "$work/$kind" --no-cache -q ${extra[$kind]}
    echo "round $round $kind $(echo "$(date +%s.%N) - $start" | bc) s"
  done
done | tee "$work/times.txt"

python3 - "$work" <<'PY'
import glob, json, os, statistics, sys
work = sys.argv[1]
times = {}
for line in open(os.path.join(work, "times.txt")):
    _, _, kind, seconds, _ = line.split()
    times.setdefault(kind, []).append(float(seconds))
print("| pack | Forward variants | all variants | stage binaries | archive bytes | manifest bytes | cold build, 3 rounds (median) |")
print("|---|---|---|---|---|---|---|")
for kind in ("default", "scene", "usage"):
    manifest_path = glob.glob(os.path.join(work, kind, "*.manifest.json"))[0]
    manifest = json.load(open(manifest_path))
    forward = sum(len(p["variants"]) for p in manifest["passes"] if p["name"] == "Forward")
    every = sum(len(p["variants"]) for p in manifest["passes"])
    archive = os.path.getsize(os.path.join(work, kind, manifest["archive"]["file"]))
    t = times[kind]
    print(f"| {kind} | {forward} | {every} | {len(manifest['binaries'])} | {archive:,} | {os.path.getsize(manifest_path):,} | "
          f"{' / '.join(f'{x:.1f}' for x in t)} s ({statistics.median(t):.1f}) |")
PY
