#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The author's loop with `kiln watch` (issue 61 item 5, bench/REPORT.md "The development loop"): seconds from an
edit to the in-use pack and to the full pack, for a comment-only edit, an edit in the fog code and an edit of D_GGX,
on the default pack with one scene's usage, interleaved over rounds, medians.

A copy of shaderlib/ and variants/ is watched (`kiln watch variants/lit.pack.json --usage LOG`, warm cache after its
first round); each edit is made, its round's status line read (watch reports both times itself, from the first
change of the round, its 100 ms quiet period included), then the edit is reverted and that round read too. Nothing
is timed by this script: the numbers are watch's own.

The usage log: --usage LOG, a run recorded by `kiln test --usage-log` (bench/usage_packs.sh records the audit
scene's: 25 stage sources), which is what the goals are stated for. Without it, a log made from the scene profile
(`kiln list --scene variants/scenes/audit.json --json`: every variant the scene can request, each used once: 452
variants for audit.json, far more than a run draws), so the in-use times are then an upper bound.

  bench/watch_loop.py --kiln build/ci/compiler/kiln [--rounds 3] [--usage LOG] [--scene variants/scenes/audit.json]
                      [-j N] [--json bench/results/watch_loop-<date>.json]
"""
import argparse
import datetime
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# (name, file under shaderlib/, text, replacement for round r): each changes what its name says and nothing else, and
# differently in every round, so that no round finds its edit in the cache from an earlier one (as an author's new
# edit would not). The fog edit is in the FOG_EXP branch the default pack compiles (not the folded one).
EDITS = [
    ("comment", "BRDF.hlsl", "// Burley 2012, \"Physically-Based Shading at Disney\". Takes",
     lambda r: "// Burley 2012 (edited comment %d), \"Physically-Based Shading at Disney\". Takes" % r),
    ("fog", "Fog.hlsl", "return saturate(exp2(-fogParams.x * distance * 1.44269504));  // exp(-d x)",
     lambda r: "return saturate(exp2(-fogParams.x * distance * (1.44269504 + %d.0e-6)));  // exp(-d x)" % (r + 1)),
    ("brdf", "BRDF.hlsl", "return saturateMediump(k * k * (real)INV_PI);",
     lambda r: "return saturateMediump(k * k * (real)(INV_PI * (1.0 + %d.0e-4)));" % (r + 1)),
]
STATUS = re.compile(r"round (\d+): (.*)")
SECONDS = re.compile(r"([\d.]+) s\b")


def usage_from_scene(kiln, pack, scene, out):
    listing = json.loads(subprocess.run([kiln, "list", pack, "--scene", scene, "--json"], capture_output=True,
                                        text=True, check=True).stdout)
    passes = {}
    for variant in listing["variants"]:
        passes.setdefault(variant["pass"], []).append({"keywords": sorted(variant["keywords"]), "count": 1})
    log = {"format": "kiln-usage", "format_version": 1, "pack": listing["pack"], "tags": {},
           "passes": [{"name": name, "served": served, "missing": []} for name, served in passes.items()],
           "missing_dropped": 0}
    with open(out, "w") as f:
        json.dump(log, f)
    return sum(len(s) for s in passes.values())


def read_round(watch, number):
    """Watch's status line of round `number` (standard output, one line a round)."""
    for line in watch.stdout:
        match = STATUS.search(line)
        if match and int(match.group(1)) >= number:
            return line.strip()
    raise SystemExit("kiln watch ended before round %d" % number)


def times_of(line):
    """(in-use seconds, full seconds) from a status line: 'in use: ..., X s; full: ..., Y s'."""
    in_use = line.split("in use:", 1)[1].split(";", 1)[0] if "in use:" in line else ""
    full = line.split("full:", 1)[1].split(";", 1)[0] if "full:" in line else ""
    first = lambda text: float(SECONDS.findall(text)[-1]) if SECONDS.findall(text) else None
    return first(in_use), first(full)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--usage")
    parser.add_argument("--scene", default=os.path.join(SOURCE, "variants/scenes/audit.json"))
    parser.add_argument("-j", "--jobs", type=int, default=0)
    parser.add_argument("--json")
    args = parser.parse_args()
    kiln = os.path.abspath(args.kiln)
    work = tempfile.mkdtemp(prefix="kiln-watch-loop-")
    try:
        for tree in ("shaderlib", "variants"):
            shutil.copytree(os.path.join(SOURCE, tree), os.path.join(work, tree))
        pack = os.path.join(work, "variants/lit.pack.json")
        usage = os.path.join(work, "usage.json")
        if args.usage:
            shutil.copy(args.usage, usage)
            asked = None
        else:
            asked = usage_from_scene(kiln, pack, args.scene, usage)
        command = [kiln, "watch", pack, "-o", os.path.join(work, "out"), "--cache", os.path.join(work, "cache"),
                   "--usage", usage]
        if args.jobs:
            command += ["-j", str(args.jobs)]
        watch = subprocess.Popen(command, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        try:
            first = read_round(watch, 1)
            print("round 1 (cold):", first, flush=True)
            number, rows = 1, []
            for r in range(args.rounds):
                for name, file, text, replacement in EDITS:
                    path = os.path.join(work, "shaderlib", file)
                    original = open(path).read()
                    assert original.count(text) == 1, (file, text)
                    for kind, content in (("edit", original.replace(text, replacement(r))), ("revert", original)):
                        with open(path + ".tmp", "w") as f:  # as an editor saves: a new file renamed over the old
                            f.write(content)
                        os.rename(path + ".tmp", path)
                        number += 1
                        line = read_round(watch, number)
                        in_use, full = times_of(line)
                        rows.append({"round": r, "edit": name, "kind": kind, "in_use_s": in_use, "full_s": full,
                                     "line": line})
                        print(r, name, kind, in_use, full, flush=True)
        finally:
            watch.terminate()
            watch.wait(timeout=120)
        summary = {}
        for name, _, _, _ in EDITS:
            for kind in ("edit", "revert"):
                picked = [row for row in rows if row["edit"] == name and row["kind"] == kind]
                summary["%s %s" % (name, kind)] = {
                    "in_use_s_median": statistics.median(row["in_use_s"] for row in picked if row["in_use_s"] is not None),
                    "full_s_median": statistics.median(row["full_s"] for row in picked if row["full_s"] is not None),
                    "rounds": len(picked)}
        for key, value in summary.items():
            print("%-16s in use %6.2f s   full %6.2f s   (%d rounds)" % (key, value["in_use_s_median"],
                                                                      value["full_s_median"], value["rounds"]))
        if args.json:
            head = subprocess.run(["git", "-C", SOURCE, "rev-parse", "--short", "HEAD"], capture_output=True,
                                  text=True).stdout.strip()
            with open(args.json, "w") as f:
                json.dump({"date": datetime.datetime.utcnow().strftime("%Y-%m-%dT%H:%M:%SZ"), "kiln": head,
                           "cores": os.cpu_count(), "load_average": os.getloadavg(), "usage_variants": asked,
                           "cold_round": first, "rows": rows, "summary": summary}, f, indent=1)
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
