#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The first use of an on-demand variant (issue 61 items 3 and 5, bench/REPORT.md "The development loop"): seconds
from a development reader's request to the pack that serves it, for variants the in-use pack lacks, on the default
pack with one scene's usage.

`kiln watch variants/lit.pack.json --usage LOG --in-use-only --serve 127.0.0.1:0` builds the in-use pack; then N
variants of the pack that the log does not ask for (a seeded sample of `kiln list --json`) are asked for one at a
time (POST /v1/variant, as kiln::DevelopmentReader sends it), each answered once watch has published a pack with it.
The times are watch's own status lines (`request ...: built into <archive>, X s`: from the request's arrival to the
pack's publication, the in-use build included). Twice: with a cold cache (each variant compiled, what an author's
first look at it costs), then with a second watch on the same cache into a new directory (each variant from the cache).

  bench/on_demand.py --kiln build/ci/compiler/kiln [--usage LOG] [--requests 10] [-j N] [--json FILE]
"""
import argparse
import datetime
import json
import os
import random
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from watch_loop import usage_from_scene  # noqa: E402  (the same log from a scene profile)

SOURCE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REQUEST = re.compile(r"kiln watch: request (.*): (built into|in) (\S+), ([\d.]+) s$")


def line_matching(watch, pattern):
    for line in watch.stdout:
        if re.search(pattern, line):
            return line.strip()
    raise SystemExit("kiln watch ended before a line matching %r" % pattern)


def serve_requests(kiln, pack, usage, work, out, jobs, variants):
    command = [kiln, "watch", pack, "-o", out, "--cache", os.path.join(work, "cache"), "--usage", usage,
               "--in-use-only", "--serve", "127.0.0.1:0"]
    if jobs:
        command += ["-j", str(jobs)]
    watch = subprocess.Popen(command, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    opener = urllib.request.build_opener(urllib.request.ProxyHandler({}))  # loopback, never a proxy
    rows = []
    try:
        endpoint = line_matching(watch, r"serving variants on http://").split("http://", 1)[1].split(" ", 1)[0]
        first = line_matching(watch, r"round 1: ")
        for variant in variants:
            body = json.dumps({"pass": variant["pass"], "keywords": variant["keywords"]}).encode()
            answer = json.loads(opener.open(urllib.request.Request("http://" + endpoint, data=body), timeout=600).read())
            match = REQUEST.search(line_matching(watch, r"kiln watch: request "))
            rows.append({"pass": variant["pass"], "keywords": variant["keywords"], "archive": answer["archive"],
                         "compiled": answer["compiled"], "seconds": float(match.group(4))})
            print("%-60s %s %.2f s" % (" ".join(variant["keywords"])[:60], match.group(2), rows[-1]["seconds"]), flush=True)
    finally:
        watch.terminate()
        watch.wait(timeout=120)
    return first, rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--usage")
    parser.add_argument("--scene", default=os.path.join(SOURCE, "variants/scenes/audit.json"))
    parser.add_argument("--requests", type=int, default=10)
    parser.add_argument("-j", "--jobs", type=int, default=0)
    parser.add_argument("--json")
    args = parser.parse_args()
    kiln = os.path.abspath(args.kiln)
    pack = os.path.join(SOURCE, "variants/lit.pack.json")
    work = tempfile.mkdtemp(prefix="kiln-on-demand-")
    try:
        usage = os.path.join(work, "usage.json")
        if args.usage:
            shutil.copy(args.usage, usage)
        else:
            usage_from_scene(kiln, pack, args.scene, usage)
        log = json.load(open(usage))
        used = {(p["name"], tuple(sorted(r["keywords"]))) for p in log["passes"] for r in p["served"] + p["missing"]}
        listing = json.loads(subprocess.run([kiln, "list", pack, "--json"], capture_output=True, text=True,
                                            check=True).stdout)
        candidates = [{"pass": v["pass"], "keywords": sorted(v["keywords"])} for v in listing["variants"]
                      if (v["pass"], tuple(sorted(v["keywords"]))) not in used]
        variants = random.Random(61).sample(candidates, min(args.requests, len(candidates)))
        result = {}
        for phase, out in (("cold cache", "out-cold"), ("from the cache", "out-warm")):
            print(phase + ":", flush=True)
            first, rows = serve_requests(kiln, pack, usage, work, os.path.join(work, out), args.jobs, variants)
            seconds = [row["seconds"] for row in rows]
            result[phase] = {"in_use_round": first, "rows": rows, "median_s": statistics.median(seconds),
                             "max_s": max(seconds)}
            print("  %s: median %.2f s, max %.2f s over %d requests" % (phase, statistics.median(seconds), max(seconds),
                                                                      len(rows)), flush=True)
        if args.json:
            head = subprocess.run(["git", "-C", SOURCE, "rev-parse", "--short", "HEAD"], capture_output=True,
                                  text=True).stdout.strip()
            with open(args.json, "w") as f:
                json.dump({"date": datetime.datetime.utcnow().strftime("%Y-%m-%dT%H:%M:%SZ"), "kiln": head,
                           "cores": os.cpu_count(), "load_average": os.getloadavg(), "usage": args.usage or args.scene,
                           "results": result}, f, indent=1)
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
