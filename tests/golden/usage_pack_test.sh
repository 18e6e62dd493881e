#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# golden.usage_pack_serves_the_recorded_run (issue 42 item 5, docs/usage.md): a run of the adversarial scene over the
# default pack records its usage log as a game would (kiln test --usage-log: the 14 variants the scene judges,
# selected by their keywords, and the shadow casters), a pack is built from that log alone, check-usage finds every
# recorded request in it, and the same scene renders every one of those variants from the usage pack within the
# golden tolerances against the CPU reference. The usage pack is narrower than the pack of the scene's own profile.
#   usage_pack_test.sh KILN SOURCE_DIR GOLDEN_WORK_DIR
set -euo pipefail
kiln=$1 source=$2 golden_work=$3
work=$golden_work/usage-pack
rm -rf "$work" && mkdir -p "$work"
scene="$source/variants/scenes/render/audit.json"
goldens="$golden_work/goldens/audit"
tolerances="$source/variants/scenes/render/tolerances.json"

"$kiln" test "$golden_work/packs/lit" --scene "$scene" --golden "$goldens" --tolerances "$tolerances" \
  --usage-log "$work/audit-run.json" > "$work/run.log" || { cat "$work/run.log"; echo "FAIL: the recorded run failed"; exit 1; }
grep -q "^kiln test: 14 passed, 0 failed, 0 not run" "$work/run.log" || { cat "$work/run.log"; echo "FAIL: not the 14 judged variants"; exit 1; }

# Built from the log alone, from the cache golden.setup filled: nothing is compiled.
"$kiln" build "$source/variants/lit.pack.json" -o "$work/pack" --cache "$golden_work/cache" --usage "$work/audit-run.json" \
  > "$work/build.log"
cat "$work/build.log"
"$kiln" check-usage "$work/pack" "$work/audit-run.json" > "$work/check.log" || { cat "$work/check.log"; echo "FAIL: check-usage"; exit 1; }
grep -q ": 0 not in the pack (0 selections)" "$work/check.log" || { cat "$work/check.log"; exit 1; }

"$kiln" test "$work/pack" --scene "$scene" --golden "$goldens" --tolerances "$tolerances" --report "$work/report" \
  > "$work/usage-pack.log" || { cat "$work/usage-pack.log"; echo "FAIL: the usage pack fails the golden test"; exit 1; }
grep -q "^kiln test: 14 passed, 0 failed, 0 not run" "$work/usage-pack.log" || { cat "$work/usage-pack.log"; exit 1; }

# Every Forward variant of the usage pack is one the run asked for, and it is narrower than the scene profile's pack.
python3 - "$work/pack" "$golden_work/packs/audit" "$work/audit-run.json" <<'PY'
import glob, json, os, sys
def forward(pack):
    manifest = json.load(open(glob.glob(os.path.join(pack, "*.manifest.json"))[0]))
    variants = [sorted(v["keywords"]) for p in manifest["passes"] if p["name"] == "Forward" for v in p["variants"]]
    archive_bytes = os.path.getsize(os.path.join(pack, manifest["archive"]["file"]))
    return variants, archive_bytes
usage, usage_size = forward(sys.argv[1])
profile, profile_size = forward(sys.argv[2])
log = json.load(open(sys.argv[3]))
asked = [sorted(r["keywords"]) for p in log["passes"] if p["name"] == "Forward" for r in p["served"]]
assert sorted(usage) == sorted(asked), f"usage pack {usage} != asked {asked}"
assert len(usage) < len(profile) and usage_size < profile_size, (len(usage), len(profile), usage_size, profile_size)
print(f"usage pack: {len(usage)} Forward variants, archive {usage_size} bytes; "
      f"the audit scene profile's pack: {len(profile)}, {profile_size} bytes")
PY
echo "usage pack test passed"
