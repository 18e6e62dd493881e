#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""How kiln's build time grows with the number of keywords (issue 3, part 1).

A synthetic shader with K fragment keywords (`#pragma multi_compile_fragment _ KW_i`, each changing the
code) gives 2^K variants; the vertex stage reads none of them, so it compiles once. For K = 4..12 (16 to
4096 variants) this runs a cold build (empty cache, all four targets, -jN) and times it; for larger K it
times only planning (`kiln list`, expansion and stripping, no compiles) to show the plan is not the limit.

usage: python3 bench/scaling.py --kiln build/ci/compiler/kiln [--max-keywords 12] [--out bench/results/scaling.json]
"""
import argparse
import json
import os
import shutil
import subprocess
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def write_pack(work, keywords, budget):
    lines = [f"#pragma multi_compile_fragment _ KW_{i}" for i in range(keywords)]
    lines += [
        "float4 SynthVertex(float3 positionOS : POSITION) : SV_Position { return float4(positionOS, 1.0); }",
        "float4 SynthFragment(float4 positionCS : SV_Position) : SV_Target",
        "{",
        "    float3 c = float3(positionCS.xy * 0.01, 0.5);",
    ]
    for i in range(keywords):
        # Distinct, non-foldable work per keyword so that every variant is a different binary.
        lines += [f"#if defined(KW_{i})", f"    c = sin(c * {1.5 + i * 0.25:.2f}) + {0.01 * (i + 1):.2f};", "#endif"]
    lines += ["    return float4(c, 1.0);", "}"]
    with open(os.path.join(work, "synth.hlsl"), "w") as f:
        f.write("\n".join(lines) + "\n")
    pack = {
        "name": "synth",
        "targets": ["spirv", "glsl", "gles", "msl"],
        "budget": budget,
        "passes": [{"name": "Main", "source": "synth.hlsl",
                    "stages": {"vertex": "SynthVertex", "fragment": "SynthFragment"}}],
    }
    path = os.path.join(work, "synth.pack.json")
    with open(path, "w") as f:
        json.dump(pack, f)
    return path


def timed(cmd):
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"command failed ({proc.returncode}): {' '.join(cmd)}\n{proc.stderr[-2000:]}")
    return elapsed, proc.stdout


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--max-keywords", type=int, default=12)
    parser.add_argument("--plan-keywords", type=int, default=16)
    parser.add_argument("--jobs", type=int, default=os.cpu_count())
    parser.add_argument("--out", default=os.path.join(ROOT, "bench/results/scaling.json"))
    args = parser.parse_args()
    kiln = os.path.abspath(args.kiln)
    rows = []
    for keywords in range(4, args.plan_keywords + 1, 2):
        work = tempfile.mkdtemp(prefix="kiln-scaling-")
        try:
            pack = write_pack(work, keywords, budget=2 ** keywords)
            plan_s, listing = timed([kiln, "list", pack, "--json"])
            row = {"keywords": keywords, "variants": 2 ** keywords, "plan_s": plan_s}
            if keywords <= args.max_keywords:
                out = os.path.join(work, "out")
                build_s, summary = timed([kiln, "build", pack, "-o", out, "--cache", os.path.join(work, "cache"),
                                          "-j", str(args.jobs)])
                manifest = json.load(open(os.path.join(out, "synth.manifest.json")))
                row.update({"build_s": build_s, "funnel": manifest["funnel"], "summary": summary.strip()})
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "summary"}), flush=True)
        finally:
            shutil.rmtree(work, ignore_errors=True)
    result = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "jobs": args.jobs, "rows": rows}
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)


if __name__ == "__main__":
    main()
