#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Golden margins and the mutation score (issue 23 items 5 and 6), as markdown for
bench/REPORT.md, "Golden tolerances and the mutation gate".

Reads what a `ctest -L golden` run left: the ctest log (every `kiln test` line: the four measures of each
comparison and the classes that set its limits) and the mutation gate's JSON files. For each tolerance class and
measure it prints the worst passing comparison, the limit and their ratio (the issue's target: the worst passing
variant within 1.3x of its limit), per scene; then each mutant with the comparison that killed it.

  golden_margins.py BUILD_DIR            (reads BUILD_DIR/Testing/Temporary/LastTest.log and
                                          BUILD_DIR/tests/golden-work/mutation-shard*.json)
"""
import glob
import json
import os
import re
import sys

LINE = re.compile(r"^(PASS|FAIL) +#(\d+) (.*?): pixels over (\d+)/255 ([\d.]+)% of (\d+) shaded \(limit ([\d.]+)%\), "
                  r"worst (\d+)/255 \(limit (\d+)\), relative RMSE ([\d.e+-]+) \(limit ([\d.e+-]+)\), "
                  r"tie pixels skipped \(shadow test, coverage\) (\d+) = ([\d.]+)% \(limit ([\d.]+)%\)(?:, \d+ NaN/Inf values)? \[(.*?)\]")
MEASURES = [("fraction over 2/255", "over", "limit_over", lambda v: f"{v:.3f}%"),
            ("worst pixel", "worst", "limit_worst", lambda v: f"{v:.0f}/255"),
            ("relative RMSE", "rmse", "limit_rmse", lambda v: f"{v:.2e}"),
            ("ties skipped", "skipped", "limit_skipped", lambda v: f"{v:.3f}%")]


def comparisons(log_path):
    test = ""
    for line in open(log_path, errors="replace"):
        m = re.match(r"^\d+/\d+ Testing: (\S+)", line)
        if m:
            test = m.group(1)
            continue
        m = LINE.match(line)
        if not m:
            continue
        g = m.groups()
        scene = next((s for s in ("night_city", "audit", "vs_vulkan") if s in test), "spheres")
        api = "gles" if ".gles" in test else "gl" if ".gl" in test else "vulkan"
        yield {"test": test, "scene": scene, "api": api, "passed": g[0] == "PASS", "variant": g[2],
               "over": float(g[4]), "limit_over": float(g[6]), "worst": int(g[7]), "limit_worst": int(g[8]),
               "rmse": float(g[9]), "limit_rmse": float(g[10]), "skipped": float(g[12]), "limit_skipped": float(g[13]),
               "classes": g[14]}


def main():
    build = sys.argv[1] if len(sys.argv) > 1 else "build/ci"
    rows = [c for c in comparisons(os.path.join(build, "Testing/Temporary/LastTest.log")) if c["scene"] != "vs_vulkan"]
    w = print
    w("## 10. Golden tolerances with teeth, and the mutation gate (issue 23 items 4-6)")
    w("")
    import datetime
    stamp = datetime.datetime.fromtimestamp(os.path.getmtime(os.path.join(build, "Testing/Temporary/LastTest.log")),
                                            datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    w(f"Measured by `bench/golden_margins.py` from one `ctest -L golden` run ({stamp}; {len(rows)} comparisons of rendered images"
      " with the CPU reference, on every API: Vulkan on lavapipe, GLSL 450 and GLSL ES on llvmpipe). Each measure"
      " is taken over the shaded pixels only (the background does not dilute it); ties are shadow-test and coverage"
      " ties. Per class and measure, over the comparisons whose limit that class sets (the loosest of the classes"
      " a variant matches), the worst comparison, its limit, and limit / worst (the target is at most 1.3):")
    w("")
    # Which class sets each measure's limit of a comparison: the first, in file order, of the classes it matched
    # whose limit for that measure is the loosest (kiln test takes the loosest).
    classes = json.load(open(os.path.join(os.path.dirname(__file__), "../variants/scenes/render/tolerances.json")))["classes"]
    fields = {"over": "max_fraction_over", "worst": "max_worst_difference", "rmse": "max_relative_rmse",
              "skipped": "max_fraction_skipped"}
    def binding(c, key):
        matched = [k for k in classes if k["name"] in c["classes"].split("+")]
        return max(matched, key=lambda k: k[fields[key]])["name"]
    w("| class | " + " | ".join(f"{name}: worst / limit (ratio), comparisons" for name, *_ in MEASURES) + " |")
    w("|---|" + "---|" * len(MEASURES))
    for cls in [k["name"] for k in classes]:
        cells = []
        for _, key, limit, fmt in MEASURES:
            bound = [c for c in rows if binding(c, key) == cls]
            if not bound:
                cells.append("(sets no limit)")
                continue
            worst = max(bound, key=lambda c: c[key])
            ratio = f"{worst[limit] / worst[key]:.2f}" if worst[key] > 0 else "-"
            cells.append(f"{fmt(worst[key])} / {fmt(worst[limit])} ({ratio}), {len(bound)}")
        w(f"| {cls} | " + " | ".join(cells) + " |")
    w("")
    w("Per scene, every comparison (the night_city scene's fp32 variants are far inside the fp32 limits, which the"
      " spheres scene sets):")
    w("")
    w("| scene | comparisons | " + " | ".join(f"{name}: worst" for name, *_ in MEASURES) + " |")
    w("|---|---|" + "---|" * len(MEASURES))
    for scene in ("spheres", "night_city", "audit"):
        mine = [c for c in rows if c["scene"] == scene]
        if mine:
            w(f"| {scene} | {len(mine)} | " + " | ".join(fmt(max(c[key] for c in mine)) for _, key, _, fmt in MEASURES) + " |")
    failed = [c for c in rows if not c["passed"]]
    w("")
    w(f"Failed comparisons in this run: {len(failed)}.")
    for c in failed[:10]:
        w(f"- {c['test']}: {c['variant']}")

    outcomes = []
    for path in sorted(glob.glob(os.path.join(build, "tests/golden-work/mutation-shard*.json"))):
        outcomes += json.load(open(path))["mutations"]
    if outcomes:
        killed = sum(o["killed"] for o in outcomes)
        w("")
        w(f"### Mutation score: {killed} of {len(outcomes)} mutants killed")
        w("")
        w("`ctest -L mutation` applies each mutation of `tests/mutation/mutations.json` to a copy of `shaderlib/`, builds"
          " the variants its scene profile keeps and compares them with the unmodified library's reference images on"
          " Vulkan, GL 4.5 and GLES 3.2; a mutant is killed when, on every API, a variant fails by at least 1.5 times one"
          " of its limits. Per API: variants failed of those judged, and the margin (the failing variant's largest"
          " measure / limit); then the comparison with the largest margin on Vulkan:")
        w("")
        w("| mutant | file | scene | failed, margin per API | worst failing variant on Vulkan: pixels over 2/255, worst pixel, relative RMSE (limits) |")
        w("|---|---|---|---|---|")
        for o in sorted(outcomes, key=lambda o: o["name"]):
            parts, first = [], ""
            for api, r in o["apis"].items():
                parts.append(f"{api} {r['failed']}/{r['variants']}, {r.get('margin', 0):.1f}x" if r["failed"] else f"{api}: survived")
                m = LINE.match("FAIL     #0 " + r["first_failure"]) if r["first_failure"] else None
                if m and not first:
                    g = m.groups()
                    first = (f"{g[3 + 1]}% ({g[6]}%), {g[7]}/255 ({g[8]}), {g[9]} ({g[10]})")
            w(f"| `{o['name']}` | {o['file']} | {o['scene']} | {'; '.join(parts)} | {first} |")

if __name__ == "__main__":
    main()
