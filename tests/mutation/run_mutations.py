#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The mutation gate (issue 23 item 6): every plausible physics or shader-logic bug in mutations.json must fail
the golden comparison.

For each mutation: copy shaderlib/ and variants/ to a scratch directory, replace one snippet that must occur
exactly once in one file, build the few variants its scene profile keeps (`kiln build --scene`), render them with
`kiln test` and compare them with the CPU reference's images of the unmodified library (golden.setup.<scene>'s),
under the suite's tolerance file, on every API (Vulkan on lavapipe, GLSL 450 and GLSL ES on llvmpipe) but those
its "not_on" names with the reason the API cannot show it. On one API a mutant is killed when `kiln test` fails at
least one variant, and killed with margin when a failing variant is at least MARGIN times over one of its limits.
The mutant is killed when it is killed with margin on every API it runs on; it survives otherwise. A mutation whose
snippet is missing, that does not compile, or whose variants have no reference image is an error of the gate,
never a kill.

With --coverage (golden.coverage's coverage.json, docs/coverage.md), a mutation whose lines hold code that no pixel
of its scene runs is NOT COVERED: it is not judged (a kill or a survival there would be luck) and fails the gate
like a survivor. A mutation of lines without code of their own (a macro's definition) is judged as usual.

  run_mutations.py --kiln KILN --source SOURCE_DIR --work DIR --goldens GOLDEN_WORK/goldens
                   [--shard I/N] [--only NAME] [--json FILE] [--mutations FILE] [--coverage FILE]

Exit 0 when every mutation of the shard was killed; 1 when one survived, was not covered, or the gate itself failed.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import time

FAIL_LINE = re.compile(r"^FAIL +#\d+ (.*?): (.*)$")
OVER = re.compile(r"; over the limit: (.*)$")
# The measures of a comparison and their limits, as kiln test prints them.
MEASURES = re.compile(r"pixels over 2/255 ([\d.]+)% of \d+ shaded \(limit ([\d.]+)%\), worst (\d+)/255 \(limit (\d+)\), "
                      r"relative RMSE ([\d.e+-]+) \(limit ([\d.e+-]+)\)")
APIS = ["vulkan", "gl", "gles"]
MARGIN = 1.5


def margin(comparison):
    """How far a failed comparison is over its limits: the largest measure / limit."""
    m = MEASURES.search(comparison)
    if not m:
        return 0.0
    v = [float(x) for x in m.groups()]
    return max(v[i] / v[i + 1] for i in (0, 2, 4) if v[i + 1] > 0)


def apply(mutation, shaderlib):
    path = os.path.join(shaderlib, mutation["file"])
    with open(path, encoding="utf-8") as f:
        text = f.read()
    count = text.count(mutation["find"])
    if count != 1:
        raise RuntimeError(f"{mutation['file']}: the snippet to mutate occurs {count} times, not once; "
                           f"update tests/mutation/mutations.json to the library:\n  {mutation['find']!r}")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text.replace(mutation["find"], mutation["replace"]))


def mutated_lines(mutation, source):
    """The 1-based lines of the library file the snippet spans."""
    with open(os.path.join(source, "shaderlib", mutation["file"]), encoding="utf-8") as f:
        text = f.read()
    at = text.find(mutation["find"])
    first = text.count("\n", 0, at) + 1
    return list(range(first, first + mutation["find"].count("\n") + 1))


def coverage_of(mutation, source, coverage):
    """'lit', 'dark' or 'no code': what the golden coverage of the mutant's scene says of its lines."""
    scene = mutation.get("scene", "spheres")
    hits = coverage["scenes"].get(scene, {}).get(mutation["file"], {})
    counts = [hits[str(n)] for n in mutated_lines(mutation, source) if str(n) in hits]
    if not counts:
        return "no code"
    return "lit" if any(counts) else "dark"


def run_one(mutation, args, log):
    name = mutation["name"]
    scratch = os.path.join(args.work, name)
    shutil.rmtree(scratch, ignore_errors=True)
    os.makedirs(scratch)
    shutil.copytree(os.path.join(args.source, "shaderlib"), os.path.join(scratch, "shaderlib"))
    shutil.copytree(os.path.join(args.source, "variants"), os.path.join(scratch, "variants"))
    apply(mutation, os.path.join(scratch, "shaderlib"))
    profile = os.path.join(scratch, "profile.json")
    with open(profile, "w") as f:
        json.dump({"name": f"mutation-{name}", "uses": mutation["uses"], "materials": mutation["materials"]}, f)
    pack = os.path.join(scratch, "pack")
    build = subprocess.run([args.kiln, "build", os.path.join(scratch, "variants", "lit.pack.json"), "--scene", profile,
                            "-o", pack, "--cache", os.path.join(args.work, "cache"), "-q"],
                           capture_output=True, text=True)
    if build.returncode != 0:
        raise RuntimeError(f"the mutant does not compile (a mutation must still compile):\n{build.stdout}{build.stderr}")
    scene = mutation.get("scene", "spheres")
    results = {}
    for api in [a for a in APIS if a not in mutation.get("not_on", {})]:
        test = subprocess.run([args.kiln, "test", pack, "--api", api,
                               "--scene", os.path.join(args.source, "variants/scenes/render", scene + ".json"),
                               "--golden", os.path.join(args.goldens, scene),
                               "--tolerances", os.path.join(args.source, "variants/scenes/render/tolerances.json")],
                              capture_output=True, text=True)
        log.write(f"## {name} ({scene}, {api})\n{test.stdout}{test.stderr}\n")
        if "NOT RUN" in test.stdout or test.returncode not in (0, 1):
            raise RuntimeError(f"kiln test could not judge the mutant on {api} (exit {test.returncode}):\n"
                               f"{test.stdout}{test.stderr}")
        failed = [m for m in (FAIL_LINE.match(line) for line in test.stdout.splitlines()) if m]
        passed = sum(1 for line in test.stdout.splitlines() if line.startswith("PASS"))
        measures = {}
        for m in failed:
            over = OVER.search(m.group(2))
            for measure in (over.group(1).split(", ") if over else ["?"]):
                measures[measure] = measures.get(measure, 0) + 1
        worst = max(failed, key=lambda m: margin(m.group(2)), default=None)
        results[api] = {"variants": passed + len(failed), "failed": len(failed), "measures": measures,
                        "margin": round(margin(worst.group(2)), 2) if worst else 0.0,
                        "first_failure": worst.group(1) + ": " + worst.group(2) if worst else None}
    killed = bool(results) and all(r["failed"] > 0 and r["margin"] >= MARGIN for r in results.values())
    return {"name": name, "file": mutation["file"], "why": mutation["why"], "scene": scene, "killed": killed,
            "apis": results, "not_on": mutation.get("not_on", {})}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--source", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("--goldens", required=True)
    parser.add_argument("--shard", default="0/1")
    parser.add_argument("--only", default="")
    parser.add_argument("--json", default="")
    parser.add_argument("--mutations", default="", help="mutation list (default: tests/mutation/mutations.json)")
    parser.add_argument("--coverage", default="", help="golden.coverage's coverage.json: mutants in dark code are not judged")
    args = parser.parse_args()
    index, count = (int(x) for x in args.shard.split("/"))
    with open(args.mutations or os.path.join(args.source, "tests/mutation/mutations.json")) as f:
        mutations = json.load(f)["mutations"]
    names = [m["name"] for m in mutations]
    if len(set(names)) != len(names):
        print("run_mutations: two mutations share a name")
        return 1
    chosen = [m for i, m in enumerate(mutations) if i % count == index and (not args.only or m["name"] == args.only)]
    os.makedirs(args.work, exist_ok=True)
    coverage = json.load(open(args.coverage, encoding="utf-8")) if args.coverage else None
    outcomes, errors, not_covered = [], [], []
    with open(os.path.join(args.work, "kiln-test.log"), "w") as log:
        for mutation in chosen:
            start = time.monotonic()
            covered = coverage_of(mutation, args.source, coverage) if coverage else None
            if covered == "dark":
                not_covered.append(mutation["name"])
                print(f"NOT COVERED {mutation['name']} [{mutation.get('scene', 'spheres')}]: no pixel of its scene runs "
                      f"{mutation['file']}:{mutated_lines(mutation, args.source)[0]} (docs/coverage.md)")
                continue
            try:
                outcome = run_one(mutation, args, log)
            except RuntimeError as e:
                errors.append(mutation["name"])
                print(f"ERROR    {mutation['name']}: {e}")
                continue
            outcome["seconds"] = round(time.monotonic() - start, 1)
            if covered:
                outcome["coverage"] = covered
            outcomes.append(outcome)
            summary = "; ".join(
                f"{api}: {r['failed']}/{r['variants']} variants failed, {r['margin']}x a limit"
                + (" (" + ", ".join(f"{k} {v}" for k, v in sorted(r["measures"].items())) + ")" if r["measures"] else "")
                for api, r in outcome["apis"].items())
            print(f"{'KILLED  ' if outcome['killed'] else 'SURVIVED'} {mutation['name']} [{outcome['scene']}]: {summary}")
            sys.stdout.flush()
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"mutations": outcomes, "errors": errors, "not_covered": not_covered}, f, indent=1)
    killed = sum(1 for o in outcomes if o["killed"])
    survived = [o["name"] for o in outcomes if not o["killed"]]
    print(f"mutation gate: {killed} of {len(chosen)} mutants killed"
          + (f"; survived: {', '.join(survived)}" if survived else "")
          + (f"; not covered: {', '.join(not_covered)}" if not_covered else "")
          + (f"; errors: {', '.join(errors)}" if errors else ""))
    return 0 if killed == len(chosen) and chosen else 1


if __name__ == "__main__":
    sys.exit(main())
