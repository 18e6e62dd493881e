#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Build-speed benchmark: kiln against the naive command-line pipeline, on the same variant list.

The naive pipeline is what a user's shell loop does for every (variant, stage):
  glslangValidator -D -V (HLSL -> SPIR-V, legalized)  ->  spirv-opt -O  ->  spirv-val
  ->  spirv-cross (GLSL 450)  ->  spirv-cross (GLSL ES 310)  ->  spirv-cross (MSL)
Each configuration runs `--reps` times, interleaved round-robin so that machine noise hits all of
them alike; the report gives medians, min-max spread and ratios against the naive pipeline.

With --floor-tool (build/ci/bench/kiln-compile-steps), one more configuration: the library floor, i.e. the
glslang, SPIRV-Tools and SPIRV-Cross calls of a cold build (every stage source's front end, every distinct
module's back end) run one after the other in one process, without anything of kiln's own; and the same
run as one process per core at once. The latter's wall time divided by the number of cores is the wall time
of an ideal parallel build with kiln's recipe and dedupe.

Usage: bench/build_speed.py --kiln build/ci/compiler/kiln [--pack variants/lit.pack.json] [--reps 3]
                            [--kiln-glibc build/glibc/compiler/kiln] [--floor-tool build/ci/bench/kiln-compile-steps]
"""
import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from anchors import chain_line, stage_jobs  # noqa: E402


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def naive_commands(kiln, pack, work):
    """The naive chain, one shell line per variant and stage (bench/anchors.py builds the lines)."""
    jobs, variants = stage_jobs(kiln, pack)
    return [chain_line(job, work) for job in jobs], variants


def compare_packs(a, b):
    """True when two output directories hold byte-identical archives and manifests."""
    names = sorted(n for n in os.listdir(a) if n.endswith((".kpack", ".manifest.json")))
    return names == sorted(n for n in os.listdir(b) if n.endswith((".kpack", ".manifest.json"))) and all(
        open(os.path.join(a, n), "rb").read() == open(os.path.join(b, n), "rb").read() for n in names)


def file_create_ms(directory, count=500):
    """Milliseconds to create one small file here: some file systems make it dear, and both sides create many."""
    os.makedirs(directory, exist_ok=True)
    start = time.perf_counter()
    for i in range(count):
        with open(os.path.join(directory, f"f{i}"), "wb") as f:
            f.write(b"kiln")
    elapsed = time.perf_counter() - start
    shutil.rmtree(directory, ignore_errors=True)
    return elapsed / count * 1000


def timed(cmd, env=None):
    """Wall time and the peak RSS of the largest child process (KiB)."""
    start = time.perf_counter()
    proc = subprocess.run(cmd, shell=isinstance(cmd, str), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    elapsed = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"command failed ({proc.returncode}): {cmd}\n{proc.stderr[-2000:]}")
    return elapsed, proc.stdout


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--kiln-glibc", help="the same kiln built with -DKILN_MIMALLOC=OFF: one more cold configuration")
    parser.add_argument("--floor-tool", help="kiln-compile-steps: times the library floor (see above)")
    parser.add_argument("--pack", default=os.path.join(ROOT, "variants/lit.pack.json"))
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=os.cpu_count())
    parser.add_argument("--out", default=os.path.join(ROOT, "bench/results/build_speed.json"))
    args = parser.parse_args()
    kiln = os.path.abspath(args.kiln)
    work = tempfile.mkdtemp(prefix="kiln-bench-")
    try:
        lines, variant_count = naive_commands(kiln, args.pack, os.path.join(work, "naive"))
        os.makedirs(os.path.join(work, "naive"))
        script = os.path.join(work, "naive.sh")
        with open(script, "w") as f:
            f.write("set -e\n" + "\n".join(lines) + "\n")
        joblist = os.path.join(work, "naive.jobs")
        with open(joblist, "w") as f:
            f.write("\n".join(lines) + "\n")

        # An include that only some variants read: Fog.hlsl is included only by the fog variants.
        fog = os.path.join(ROOT, "shaderlib/Fog.hlsl")
        original = open(fog).read()
        code_anchor = "max(fogParams.z - fogParams.y, 1e-4)"
        assert code_anchor in original, "bench/build_speed.py: the FOG_LINEAR code it edits has moved"

        def comment_edit(n):
            # Changes the text of every fog variant, not the code any entry point reaches.
            return original + f"\n// benchmark edit {n}\nfloat KilnBenchEdit{n}() {{ return 0.0; }}\n"

        def code_edit(n):
            # Changes FOG_LINEAR's code: those variants' modules change, the other fog variants' do not.
            return original.replace(code_anchor, f"max(fogParams.z - fogParams.y, {1e-4 + (n + 1) * 1e-7:.7e})")

        def kiln_cmd(out, cache, jobs, exe=kiln):
            return [exe, "build", args.pack, "-o", out, "--cache", cache, "-j", str(jobs), "-q"]

        def cold(jobs, exe=kiln):
            tag = f"{jobs}" if exe == kiln else f"{jobs}-other"
            out, cache = os.path.join(work, f"cold{tag}"), os.path.join(work, f"cache-cold{tag}")
            shutil.rmtree(out, ignore_errors=True)
            shutil.rmtree(cache, ignore_errors=True)
            return timed(kiln_cmd(out, cache, jobs, exe))[0]

        warm_out, warm_cache = os.path.join(work, "warm"), os.path.join(work, "cache-warm")
        timed(kiln_cmd(warm_out, warm_cache, args.jobs))  # prime the cache

        def warm_full_cache():
            # Pack removed, cache full: every compile is a cache hit.
            shutil.rmtree(warm_out, ignore_errors=True)
            return timed(kiln_cmd(warm_out, warm_cache, args.jobs))[0]

        def no_change():
            return timed(kiln_cmd(warm_out, warm_cache, args.jobs))[0]

        edit_counter = [0]

        def with_edit(text, cmd):
            with open(fog, "w") as f:
                f.write(text)
            try:
                return timed(cmd)
            finally:
                with open(fog, "w") as f:
                    f.write(original)

        def include_edit(make_text):
            def run_edit():
                edit_counter[0] += 1  # a new edit each time: never a cache hit
                return with_edit(make_text(edit_counter[0]), kiln_cmd(warm_out, warm_cache, args.jobs))[0]
            return run_edit

        def naive_serial():
            return timed(["bash", script])[0]

        def naive_parallel():
            return timed(f"xargs -P {args.jobs} -I CMD -d '\\n' bash -c CMD < {joblist}")[0]

        floor_runs = []

        def floor_sources():
            emit = os.path.join(work, "floor-emit")
            if not os.path.isdir(emit):  # the stage sources a build compiles, preprocessed (served by the warm cache)
                run([kiln, "build", args.pack, "-o", emit, "--cache", warm_cache, "-q", "--emit", "preprocessed"])
            return os.path.join(emit, "emit")

        def library_floor():
            out = os.path.join(work, "floor.json")
            timed([os.path.abspath(args.floor_tool), "--floor", floor_sources(), args.pack, "--json", out])
            floor_runs.append(json.load(open(out)))
            return floor_runs[-1]["total_s"]

        def library_floor_side_by_side():
            # One copy per core at once: the wall time of twice (for 2 cores) the floor's work on all cores,
            # with whatever the cores share (caches, memory bandwidth, the host) counted. Halved, the ideal build.
            cmd = [os.path.abspath(args.floor_tool), "--floor", floor_sources(), args.pack]
            start = time.perf_counter()
            procs = [subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE) for _ in range(args.jobs)]
            for proc in procs:
                _, err = proc.communicate()
                if proc.returncode != 0:
                    sys.exit(f"command failed ({proc.returncode}): {cmd}\n{err.decode()[-2000:]}")
            return time.perf_counter() - start

        configs = {f"kiln cold -j{args.jobs}": lambda: cold(args.jobs)}
        if args.kiln_glibc:
            glibc = os.path.abspath(args.kiln_glibc)
            configs[f"kiln cold -j{args.jobs}, glibc malloc"] = lambda: cold(args.jobs, glibc)
        configs.update({
            "kiln cold -j1": lambda: cold(1),
            "kiln warm (full cache, no pack)": warm_full_cache,
            "kiln no-change rebuild": no_change,
            "kiln after a code edit in Fog.hlsl": include_edit(code_edit),
            "kiln after a comment edit in Fog.hlsl": include_edit(comment_edit),
            "naive loop, serial": naive_serial,
            f"naive loop, xargs -P{args.jobs}": naive_parallel,
        })
        if args.floor_tool:
            configs["library floor, one process"] = library_floor
            configs[f"library floor, {args.jobs} processes side by side"] = library_floor_side_by_side
        samples = {name: [] for name in configs}
        for rep in range(args.reps):
            for name, fn in configs.items():
                samples[name].append(fn())
                print(f"rep {rep + 1}/{args.reps} {name}: {samples[name][-1]:.3f} s", flush=True)

        # One more instrumented build for the funnel, stage times, and what the include edit recompiled.
        cold_out = os.path.join(work, "funnel")
        funnel_cmd = [kiln, "build", args.pack, "-o", cold_out, "--cache", os.path.join(work, "cache-funnel"), "-j", str(args.jobs)]
        stats_run = run(funnel_cmd)
        edit_summaries = {"code": with_edit(code_edit(0), funnel_cmd)[1], "comment": with_edit(comment_edit(0), funnel_cmd)[1]}
        peak_kib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
        manifest = json.load(open(os.path.join(cold_out, json.load(open(args.pack))["name"] + ".manifest.json")))

        result = {
            "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                        "memory_gib": round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1)},
            "tools": manifest["tools"],
            "pack": os.path.relpath(args.pack, ROOT),
            "variants": variant_count,
            "naive_stage_compiles": len(lines),
            "funnel": manifest["funnel"],
            "kiln_summary": stats_run.stdout,
            "edit_summaries": edit_summaries,
            "glibc_pack_identical": compare_packs(os.path.join(work, f"cold{args.jobs}"), os.path.join(work, f"cold{args.jobs}-other"))
            if args.kiln_glibc else None,
            "peak_child_rss_mib": round(peak_kib / 1024, 1),
            "file_create_ms": round(file_create_ms(os.path.join(work, "file-create")), 3),
            "floor_runs": floor_runs,
            "reps": args.reps,
            "samples_s": samples,
            "median_s": {k: statistics.median(v) for k, v in samples.items()},
        }
        os.makedirs(os.path.dirname(args.out), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(result, f, indent=2)
        print(json.dumps(result["median_s"], indent=2))
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
