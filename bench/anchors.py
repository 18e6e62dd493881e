#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""kiln's cold build against what a user would pick instead, 2-wide (issue 26 item 1).

The naive chain of bench/REPORT.md's "Build throughput against the naive chains" (glslangValidator, spirv-opt -O,
spirv-val, spirv-cross x3 per variant and stage, from `kiln list --json`) run the ways a user runs it on N cores: under `xargs -P N`, and as a `build.ninja` with one edge
per tool at `ninja -j N` (what a CMake user wires with add_custom_command); `glslc -O` (shaderc: HLSL legalization
and -O in one process) in place of glslangValidator + spirv-opt under `xargs -P N`, when glslc is installed; and the
serial loop (one core) as a row. Every configuration once per round, rounds interleaved; medians; wall time and the
CPU time of the process tree (user + system), so that a ratio of walls can be read beside a ratio of work.

With --floor-tool (build/ci/bench/kiln-compile-steps), one more row: the library floor of bench/build_speed.py (the
glslang, SPIRV-Tools and SPIRV-Cross calls of kiln's recipe and dedupe, nothing of kiln's own), N copies side by side
and divided by N: the cold build of an ideal kiln on N cores, so that a goal against an anchor can be checked
against what any kiln could reach.

usage: python3 bench/anchors.py --kiln build/ci/compiler/kiln [--pack variants/lit.pack.json] [--jobs 2] [--reps 3]
                                [--no-serial] [--floor-tool build/ci/bench/kiln-compile-steps] [--only kiln,ninja,floor]
                                [--out bench/results/anchors.json]

The anchors start about 18,000 short processes (7 per stage compile); kiln starts 2 workers. Their cost therefore
moves the ratios, and it varies on a shared virtual machine: before each round the script times 200 starts of
/bin/true (fork + exec + exit, wall per start) and records them beside the results.
"""
import argparse
import json
import os
import resource
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def stage_jobs(kiln, pack):
    """One record per variant and stage: what the naive chain compiles (as bench/build_speed.py's naive loop)."""
    listing = json.loads(subprocess.run([kiln, "list", pack, "--json"], check=True, stdout=subprocess.PIPE, text=True).stdout)
    definition = json.load(open(pack))
    base = os.path.dirname(os.path.abspath(pack))
    includes = [os.path.join(base, d) for d in definition.get("include_dirs", [])]
    passes = {p["name"]: p for p in definition["passes"]}
    jobs = []
    for index, variant in enumerate(listing["variants"]):
        p = passes[variant["pass"]]
        for stage, keywords in variant["stages"].items():
            jobs.append({"name": f"{index}.{stage}", "source": os.path.join(base, p["source"]), "entry": p["stages"][stage],
                         "short": "vert" if stage == "vertex" else "frag", "defines": [f"-D{k}=1" for k in keywords],
                         "includes": [f"-I{d}" for d in includes]})
    return jobs, len(listing["variants"])


def glslang_args(job, out):
    return (["glslangValidator", "-D", "-V", "--hlsl-enable-16bit-types", "--target-env", "vulkan1.1", "-S", job["short"],
             "-e", job["entry"]] + job["defines"] + job["includes"] + [job["source"], "-o", out])


def cross_args(spv, out):
    return [["spirv-cross", spv, "--version", "450", "--output", out + ".glsl"],
            ["spirv-cross", spv, "--es", "--version", "310", "--output", out + ".es.glsl"],
            ["spirv-cross", spv, "--msl", "--output", out + ".metal"]]


def chain_line(job, work):
    out = os.path.join(work, job["name"])
    steps = [glslang_args(job, out + ".spv"), ["spirv-opt", "-O", out + ".spv", "-o", out + ".opt.spv"],
             ["spirv-val", "--target-env", "vulkan1.1", out + ".opt.spv"]] + cross_args(out + ".opt.spv", out)
    return " && ".join(" ".join(shlex.quote(a) for a in s) + (" >/dev/null" if i == 0 else "") for i, s in enumerate(steps))


def glslc_line(job, work):
    out = os.path.join(work, job["name"])
    glslc = (["glslc", "-x", "hlsl", "-fhlsl-16bit-types", f"-fshader-stage={job['short']}", f"-fentry-point={job['entry']}",
              "--target-env=vulkan1.1", "-O"] + job["defines"] + job["includes"] + [job["source"], "-o", out + ".opt.spv"])
    steps = [glslc, ["spirv-val", "--target-env", "vulkan1.1", out + ".opt.spv"]] + cross_args(out + ".opt.spv", out)
    return " && ".join(" ".join(shlex.quote(a) for a in s) for s in steps)


def ninja_file(jobs, work):
    """One edge per tool and output, as add_custom_command would make them."""
    q = lambda a: a.replace("$", "$$").replace(" ", "$ ").replace(":", "$:")
    lines = ["rule tool", "  command = $cmd", ""]
    outputs = []
    for job in jobs:
        out = os.path.join(work, job["name"])
        edges = [(out + ".spv", job["source"], glslang_args(job, out + ".spv") + [">/dev/null"]),
                 (out + ".opt.spv", out + ".spv", ["spirv-opt", "-O", out + ".spv", "-o", out + ".opt.spv"]),
                 (out + ".val", out + ".opt.spv",
                  ["spirv-val", "--target-env", "vulkan1.1", out + ".opt.spv", "&&", "touch", out + ".val"])]
        for argv in cross_args(out + ".opt.spv", out):
            edges.append((argv[-1], out + ".opt.spv", argv))
        for output, dep, argv in edges:
            lines.append(f"build {q(output)}: tool {q(dep)}")
            lines.append("  cmd = " + " ".join(a if a in (">/dev/null", "&&") else shlex.quote(a) for a in argv).replace("$", "$$"))
            outputs.append(output)
    lines.append("build all: phony " + " ".join(q(o) for o in outputs))
    lines.append("default all")
    return "\n".join(lines) + "\n"


def measure(cmd, cwd=None, copies=1):
    """Wall seconds and CPU seconds (user + system) of the whole process tree; with copies > 1, of that many
    copies of cmd started at once."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    procs = [subprocess.Popen(cmd, shell=isinstance(cmd, str), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                              cwd=cwd) for _ in range(copies)]
    errors = [proc.communicate()[1] for proc in procs]
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    for proc, err in zip(procs, errors):
        if proc.returncode != 0:
            sys.exit(f"command failed ({proc.returncode}): {cmd}\n{err[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--pack", default=os.path.join(ROOT, "variants/lit.pack.json"))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--no-serial", action="store_true", help="leave out the serial loop (the longest row)")
    parser.add_argument("--only", help="comma-separated words: run the configurations whose names contain one of them")
    parser.add_argument("--floor-tool", help="kiln-compile-steps: adds the library floor on N cores (see above)")
    parser.add_argument("--also-pack", action="append", default=[],
                        help="another pack definition for kiln to build cold beside the first (the anchors still build "
                             "the first pack's variants): a specialized pack against the naive chain of every variant")
    parser.add_argument("--out", default=os.path.join(ROOT, "bench/results/anchors.json"))
    args = parser.parse_args()
    kiln = os.path.abspath(args.kiln)
    n = args.jobs
    work = tempfile.mkdtemp(prefix="kiln-anchors-")
    loads = [open("/proc/loadavg").read().split()[0]]
    try:
        jobs, variants = stage_jobs(kiln, args.pack)
        scripts = {}

        def fresh(name):
            d = os.path.join(work, name)
            shutil.rmtree(d, ignore_errors=True)
            os.makedirs(d)
            return d

        def write_lines(name, lines):
            path = os.path.join(work, name)
            with open(path, "w") as f:
                f.write("\n".join(lines) + "\n")
            return path

        def kiln_cold():
            out = fresh("kiln")
            return measure([kiln, "build", args.pack, "-o", os.path.join(out, "pack"), "--cache", os.path.join(out, "cache"),
                            "-j", str(n), "-q"])

        def under_xargs(name, make_line):
            out = fresh(name)
            joblist = write_lines(name + ".jobs", [make_line(j, out) for j in jobs])
            return measure(f"xargs -P {n} -I CMD -d '\\n' bash -c CMD < {shlex.quote(joblist)}")

        def xargs_chain():
            return under_xargs("xargs", chain_line)

        def ninja_chain():
            out = fresh("ninja")
            with open(os.path.join(out, "build.ninja"), "w") as f:
                f.write(ninja_file(jobs, out))
            return measure(["ninja", "-j", str(n), "-C", out])

        def xargs_glslc():
            return under_xargs("glslc", glslc_line)

        def serial_chain():
            out = fresh("serial")
            script = write_lines("serial.sh", ["set -e"] + [chain_line(j, out) for j in jobs])
            return measure(["bash", script])

        def floor_sources():
            emit = os.path.join(work, "floor-emit")
            if not os.path.isdir(emit):  # the stage sources a cold build compiles, preprocessed (not timed)
                subprocess.run([kiln, "build", args.pack, "-o", emit, "--cache", os.path.join(work, "floor-cache"), "-q",
                                "--emit", "preprocessed"], check=True, stdout=subprocess.DEVNULL)
            return os.path.join(emit, "emit")

        def library_floor():
            # n copies of the whole floor at once, divided by n: n cores' worth of the floor's work, with whatever
            # the cores share counted, as an ideal build of one pack on n cores.
            wall, cpu = measure([os.path.abspath(args.floor_tool), "--floor", floor_sources(), args.pack], copies=n)
            return wall / n, cpu / n

        configs = {f"kiln cold -j{n}": kiln_cold, f"naive chain, xargs -P{n}": xargs_chain,
                   f"naive chain, build.ninja, ninja -j{n}": ninja_chain}
        for other in args.also_pack:
            def kiln_cold_other(other=other):
                out = fresh("kiln-other")
                return measure([kiln, "build", other, "-o", os.path.join(out, "pack"), "--cache", os.path.join(out, "cache"),
                                "-j", str(n), "-q"])
            configs[f"kiln cold -j{n}, {os.path.basename(other)}"] = kiln_cold_other
        have_glslc = shutil.which("glslc") is not None
        if have_glslc:
            configs[f"glslc -O chain, xargs -P{n}"] = xargs_glslc
        if not args.no_serial:
            configs["naive chain, serial loop"] = serial_chain
        if args.floor_tool:
            configs[f"library floor on {n} cores (an ideal kiln)"] = library_floor
        if args.only:
            words = args.only.split(",")
            configs = {k: v for k, v in configs.items() if k.startswith("kiln cold") or any(w in k for w in words)}
        walls = {k: [] for k in configs}
        cpus = {k: [] for k in configs}
        process_starts_ms = []

        def process_start_ms():
            start = time.perf_counter()
            for _ in range(200):
                subprocess.run(["/bin/true"], check=True)
            return (time.perf_counter() - start) / 200 * 1000

        for rep in range(args.reps):
            process_starts_ms.append(process_start_ms())
            print(f"rep {rep + 1}/{args.reps}: a process start takes {process_starts_ms[-1]:.2f} ms", flush=True)
            for name, fn in configs.items():
                wall, cpu = fn()
                walls[name].append(wall)
                cpus[name].append(cpu)
                loads.append(open("/proc/loadavg").read().split()[0])
                print(f"rep {rep + 1}/{args.reps} {name}: wall {wall:.2f} s, cpu {cpu:.2f} s", flush=True)
        kiln_name = f"kiln cold -j{n}"
        median = lambda v: statistics.median(v)
        rows = []
        for name in configs:
            rows.append({"config": name, "wall_s": median(walls[name]), "cpu_s": median(cpus[name]),
                         "wall_ratio": median(walls[name]) / median(walls[kiln_name]),
                         "cpu_ratio": median(cpus[name]) / median(cpus[kiln_name]),
                         "walls": walls[name], "cpus": cpus[name]})
        glslc_version = subprocess.run(["glslc", "--version"], stdout=subprocess.PIPE, text=True).stdout.splitlines()[0] \
            if have_glslc else None
        result = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "pack": os.path.relpath(args.pack, ROOT),
                  "variants": variants, "stage_compiles": len(jobs), "jobs": n, "reps": args.reps, "load_averages": loads,
                  "process_start_ms": process_starts_ms,
                  "glslc": glslc_version, "rows": rows}
        os.makedirs(os.path.dirname(args.out), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(result, f, indent=2)
        for r in rows:
            print(f"{r['config']}: wall {r['wall_s']:.2f} s ({r['wall_ratio']:.2f}x kiln), cpu {r['cpu_s']:.2f} s "
                  f"({r['cpu_ratio']:.2f}x kiln)")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
