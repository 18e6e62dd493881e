#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""What shader code coverage costs (bench/REPORT.md, "Shader code coverage"): the same kiln test run on three
builds of one pack, the shipped one (optimized), -g (debug information, no optimization) and --coverage (-g plus the probes), side by
side: interleaved rounds, medians, ratios. Every run compiles its pipelines cold (MESA_SHADER_CACHE_DISABLE), as a
first run does; `--coverage` runs also read the buffer back after each draw and write the tracefile.

  coverage_cost.py --kiln KILN --source SOURCE_DIR --goldens GOLDEN_WORK/goldens --work DIR [--rounds N]

Prints one row per build (seconds per run, ratio to the optimized pack) for the audit profile's 14 variants and
for a strength-3 covering sample of the default pack (68 variants) on the spheres scene."""
import argparse
import os
import statistics
import subprocess
import time


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--source", required=True)
    parser.add_argument("--goldens", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    environment = dict(os.environ, MESA_SHADER_CACHE_DISABLE="true", GALLIVM_PERF="nopt")
    cases = {"audit": (["--scene", os.path.join(args.source, "variants/scenes/audit.json")], []),
             "spheres": ([], ["--cover", "3"])}
    builds = {"optimized": [], "-g": ["-g"], "--coverage": ["--coverage"]}
    for case, (profile, sample) in cases.items():
        packs = {}
        for build, flags in builds.items():
            pack = os.path.join(args.work, f"{case}{build}")
            subprocess.run([args.kiln, "build", os.path.join(args.source, "variants/lit.pack.json"), *profile, *flags,
                            "-o", pack, "--cache", os.path.join(args.work, "cache"), "-q"], check=True)
            packs[build] = pack
        seconds = {build: [] for build in builds}
        for _ in range(args.rounds):
            for build, pack in packs.items():
                command = [args.kiln, "test", pack, *sample,
                           "--scene", os.path.join(args.source, "variants/scenes/render", case + ".json"),
                           "--golden", os.path.join(args.goldens, case),
                           "--tolerances", os.path.join(args.source, "variants/scenes/render/tolerances.json")]
                if build == "--coverage":
                    command += ["--coverage", os.path.join(args.work, case + ".info")]
                start = time.monotonic()
                subprocess.run(command, check=True, capture_output=True, env=environment)
                seconds[build].append(time.monotonic() - start)
        base = statistics.median(seconds["optimized"])
        print(f"{case} ({args.rounds} interleaved rounds, medians):")
        for build, runs in seconds.items():
            print(f"  {build:<11} {statistics.median(runs):7.2f} s  {statistics.median(runs) / base:5.2f}x  "
                  f"(runs: {', '.join(f'{s:.2f}' for s in runs)})")


if __name__ == "__main__":
    main()
