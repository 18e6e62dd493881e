#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Cold and warm `kiln test` shards side by side: the measurement behind bench/REPORT.md, "Golden verification time".

Runs one shard of the spheres golden test (default pack, as golden.setup leaves it) with each kiln-verify binary
given, interleaved, ROUNDS times per API: first from an empty Mesa shader cache (cold), then again with the cache
that run filled (warm). Prints wall seconds and the child's CPU seconds (user + sys) per run and the medians, as a
markdown table. Every run must pass (all variants of the shard PASS); a failed run stops the measurement.

  golden_shard_time.py BUILD_DIR [--binary NAME=PATH ...] [--api vulkan gl gles] [--shard 2/16] [--rounds 3]
                       [--env NAME=KEY=VALUE ...]

Without --binary it times BUILD_DIR/compiler/kiln-verify as "current". --env adds an environment variable to one
binary's runs (e.g. --binary current=... --binary nopt-off=... --env nopt-off=GALLIVM_PERF=).
"""
import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def run_once(binary, api, shard, build, source, cache, extra_env):
    work = os.path.join(build, "tests", "golden-work")
    command = [binary, "test", os.path.join(work, "packs", "lit"), "--api", api,
               "--scene", os.path.join(source, "variants/scenes/render/spheres.json"),
               "--golden", os.path.join(work, "goldens", "spheres"),
               "--tolerances", os.path.join(source, "variants/scenes/render/tolerances.json"), "--shard", shard]
    env = dict(os.environ, MESA_SHADER_CACHE_DIR=cache, **extra_env)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    result = subprocess.run(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if result.returncode != 0:
        sys.exit(f"golden_shard_time: {binary} --api {api} --shard {shard} failed:\n{result.stdout[-3000:]}")
    return wall, cpu


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("--binary", action="append", default=[], help="NAME=PATH of a kiln-verify")
    parser.add_argument("--env", action="append", default=[], help="NAME=KEY=VALUE for that binary's runs")
    parser.add_argument("--api", nargs="+", default=["vulkan", "gl"])
    parser.add_argument("--shard", default="2/16")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    source = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    binaries = dict(b.split("=", 1) for b in args.binary) or {"current": os.path.join(args.build, "compiler", "kiln-verify")}
    extra = {name: {} for name in binaries}
    for item in args.env:
        name, key, value = item.split("=", 2)
        extra[name][key] = value
    times = {}  # (api, name, "cold"|"warm") -> [(wall, cpu)]
    for round_index in range(args.rounds):
        for api in args.api:
            for name, binary in binaries.items():
                cache = tempfile.mkdtemp(prefix="kiln-mesa-cache-")
                try:
                    for state in ("cold", "warm"):
                        times.setdefault((api, name, state), []).append(
                            run_once(binary, api, args.shard, args.build, source, cache, extra[name]))
                finally:
                    shutil.rmtree(cache, ignore_errors=True)
                print(f"round {round_index + 1}: {api} {name} done", file=sys.stderr)
    print(f"`kiln test --shard {args.shard}` of spheres, {args.rounds} interleaved rounds, wall s (CPU s):\n")
    print("| API | binary | cold runs | cold median | warm runs | warm median |")
    print("|---|---|---|---|---|---|")
    for api in args.api:
        for name in binaries:
            cells = []
            for state in ("cold", "warm"):
                runs = times[(api, name, state)]
                cells.append(", ".join(f"{w:.2f} ({c:.2f})" for w, c in runs))
                cells.append(f"{statistics.median(w for w, _ in runs):.2f} ({statistics.median(c for _, c in runs):.2f})")
            print(f"| {api} | {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
