#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Writes bench/results/REPORT.generated.md and bench/plots/*.png from bench/results/*.json.

The results come from one run of bench/run_all.sh (build speed, keyword scaling, the stress gate's report,
the shading cost-versus-error study); this script only formats them and draws the plots with gnuplot. bench/REPORT.md
is a reference ordered by topic, written by hand: its sections take their current figures from the generated file
and keep the older ones in its History appendix, so this script does not overwrite it.
"""
import json
import os
import re
import statistics
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "bench/results")
PLOTS = os.path.join(ROOT, "bench/plots")


# Changes after the dated runs above that did not rerun every instrument, said where the reader meets the dates.
LATER_NOTES = [
    "- Since then (2026-11-23, not a rerun of this report): preprocessing runs in the compiler workers, not in the",
    "  main process, and the glslang front end rewrites character literals, `1.#INF` and escaped strings before",
    "  preprocessing. Interleaved A/B of cold default-pack builds on an idle machine (2 runs each, the previous",
    "  code against the new): total 25.08/26.08 s -> 24.26/24.88 s, the preprocess stage 0.99/1.04 s -> 1.24/1.31 s",
    "  (it now starts the workers, which the compile stage reuses); the machine ran about 1.5x slower that day",
    "  than in the runs below (004410b's kiln: 26.7 s cold). Every blob of the default pack is unchanged.",
    "  The figures below are from the code of their date.",
    "- 2026-11-23 (issue 23): sections 3 and 4 (the stress and accuracy gates) were rerun on the code that changed",
    "  `DirectBRDF`, `AccumulateLight` and the DFG table; sections 1, 2 and 5 were not (section 2's DFG rows",
    "  describe the previous table).",
]


def load(name):
    path = os.path.join(RESULTS, name)
    return json.load(open(path)) if os.path.exists(path) else None


def fmt_s(seconds):
    return f"{seconds * 1000:.0f} ms" if seconds < 1 else f"{seconds:.2f} s"


def fmt_e(x):
    return "0" if x == 0 else f"{x:.2e}"


def gnuplot(script):
    subprocess.run(["gnuplot"], input=script, text=True, check=True)


def slug(name):
    return "".join(c if c.isalnum() else "_" for c in name.lower()).strip("_")


def spirv_tools_share():
    """Share of a fragment compile spent in SPIRV-Tools' legalization and optimization recipes."""
    c = load("compile_steps_fragment.json")
    if not c:
        return None
    part = sum(s["median_ms"] for s in c["steps"] if s["step"] in ("legalize", "legalize (core recipe)", "optimize (-O)", "optimize (kiln's recipe)"))
    return part / c["total_ms"]


def anchors_table(w, a):
    """The rows of one bench/anchors.py run, and what they say of the 5x goal."""
    rows = {row["config"]: row for row in a["rows"]}
    n = a["jobs"]
    ninja = rows.get(f"naive chain, build.ninja, ninja -j{n}")
    floor = next((row for row in a["rows"] if row["config"].startswith("library floor")), None)
    w("| configuration | wall (median) | CPU (median) | kiln is faster, wall | kiln is faster, CPU |")
    w("|---|---|---|---|---|")
    for row in a["rows"]:
        bold = "**" if row is ninja else ""
        w(f"| {row['config']} | {row['wall_s']:.2f} s | {row['cpu_s']:.2f} s | {bold}{row['wall_ratio']:.2f}x{bold} | "
          f"{bold}{row['cpu_ratio']:.2f}x{bold} |")
    w("")
    if ninja:
        met = ninja["wall_ratio"] >= 5
        w(f"- Against the anchor a CMake user wires (`ninja -j{n}`), kiln is **{ninja['wall_ratio']:.1f}x faster in wall time and "
          f"does {ninja['cpu_ratio']:.1f}x less work**. The goal was >= 5x: **{'met' if met else 'not met'}** in this run"
          + ("" if met else f"; kiln is {100 * (1 - ninja['wall_ratio'] / 5):.0f}% short of it in wall time and "
             f"{100 * (1 - ninja['cpu_ratio'] / 5):.0f}% in CPU time") + ".")
    if ninja and floor:
        w(f"- The library floor on {n} cores ({n} copies of `kiln-compile-steps --floor` side by side, divided by {n}: the")
        w(f"  glslang, SPIRV-Tools and SPIRV-Cross calls of kiln's recipe and dedupe, nothing of kiln's own) is what an ideal")
        w(f"  kiln would take: {ninja['wall_s'] / floor['wall_s']:.1f}x faster than `ninja -j{n}`, the most any kiln with this")
        w(f"  recipe could reach in this run. kiln's median is {1 / floor['wall_ratio']:.2f}x the floor's (the rounds drifted by")
        w(f"  more than that: kiln {', '.join(f'{x:.1f}' for x in rows[f'kiln cold -j{n}']['walls'])} s, the floor "
          f"{', '.join(f'{x:.1f}' for x in floor['walls'])} s).")
    if a.get("process_start_ms") and ninja:
        chains = a["stage_compiles"]
        w(f"- A process start (fork, exec and exit of `/bin/true`, before each round) took "
          f"{', '.join(f'{x:.1f}' for x in a['process_start_ms'])} ms; the ninja anchor runs {7 * chains:,} tool processes and")
        w(f"  spent {1000 * ninja['cpu_s'] / (7 * chains):.1f} ms of CPU per tool run.")


def anchors_subsection(w, a, later=None):
    """kiln against the 2-wide anchors (bench/anchors.py), wall and CPU (issue 26 item 1); `later`, a run with the
    library floor (bench/results/anchors_2026-11-26.json)."""
    rows = {row["config"]: row for row in a["rows"]}
    n = a["jobs"]
    w(f"### Against what a user would run instead, {n}-wide (issue 26 item 1)")
    w("")
    w(f"kiln uses {n} cores; so does anything a user would pick instead. `bench/anchors.py` builds `{a['pack']}` ({a['variants']}")
    w(f"variants, {a['stage_compiles']} stage compiles) cold with kiln `-j{n}` and with {n}-wide anchors made from `kiln list --json`:")
    w("the naive chain (`glslangValidator -D -V`, `spirv-opt -O`, `spirv-val`, `spirv-cross` x3 per variant and stage)")
    w(f"under `xargs -P{n}`; the same chain as a `build.ninja` with one edge per tool and output (what `add_custom_command`")
    w(f"wires) at `ninja -j{n}`; and `glslc -O` ({a['glslc'] or 'not installed'}: legalization and `-O` in one process) with")
    w(f"`spirv-val` and `spirv-cross` under `xargs -P{n}`. The serial loop stays as a row. Each configuration once per round,")
    w(f"{a['reps']} rounds interleaved, medians; wall time and the CPU time (user + system) of the whole process tree, so that a")
    w(f"ratio of walls reads beside a ratio of work. Run of {a['date']} (its end); load average over the run "
      f"{min(float(x) for x in a['load_averages']):.1f}-{max(float(x) for x in a['load_averages']):.1f}"
      + (f". {a['conditions']}" if a.get("conditions") else "") + " (`bench/results/anchors.json` has every run).")
    w("")
    anchors_table(w, a)
    w("- Where the rest would have to come from: kiln runs close to the library floor (below), so the CPU ratio is")
    w("  bounded by what the anchors do that kiln does not (process start-ups, SPIR-V written and read between tools,")
    w("  every variant compiled where kiln compiles each distinct front end and back end once), against the glslang and")
    w("  SPIRV-Tools work both pay. `glslc -O` spends the least CPU of the anchors (front end, legalization and `-O` in")
    w("  one process).")
    serial = rows.get("naive chain, serial loop")
    if serial:
        w(f"- The serial loop reads {serial['wall_ratio']:.1f}x in wall time: half of any serial ratio is kiln using {n} cores; the")
        w(f"  CPU column says {serial['cpu_ratio']:.1f}x.")
    w("")
    if later:
        w(f"The run of {later['date']} (its end; `bench/anchors.py --only ninja,floor --floor-tool "
          f"build/ci/bench/kiln-compile-steps`, {later['reps']} rounds, load average "
          f"{min(float(x) for x in later['load_averages']):.1f}-{max(float(x) for x in later['load_averages']):.1f}"
          + (f"; {later['conditions']}" if later.get("conditions") else "") + "; `bench/results/anchors_2026-11-26.json`):")
        w("")
        anchors_table(w, later)
        per_run = lambda run: 1000 * next(r["cpu_s"] for r in run["rows"] if "ninja" in r["config"]) / (7 * run["stage_compiles"])
        w("")
        w(f"So the 5x goal is met where a tool run costs what it cost on this day ({per_run(later):.0f} ms of CPU) and missed")
        w(f"where it costs what it cost on {a['date'][:10]} ({per_run(a):.0f} ms), with kiln at or near the library floor in both: the")
        w("ratio is set by what the anchors pay per process on the machine, not by anything left in kiln. On a machine")
        w("where processes are as cheap as on the earlier day, no kiln with this recipe reaches 5x: the issue's idle")
        w("measurement put `ninja -j2` at 4.3x kiln, and section 1's run of 2026-11-22 put kiln 1.13x above the floor (17.03 s")
        w("against 15.06 s), so an ideal kiln would have been about 4.9x faster than `ninja -j2` (the earlier anchors run")
        w("has no floor row of its own).")
        w("")


def build_speed_section(w, r):
    steps_share = spirv_tools_share()
    med = r["median_s"]
    samples = r["samples_s"]
    jobs = r["machine"]["cpus"]
    naive_serial = med["naive loop, serial"]
    naive_parallel = med[f"naive loop, xargs -P{jobs}"]
    cold = med[f"kiln cold -j{jobs}"]
    cold1 = med["kiln cold -j1"]
    w("## 1. Build speed: kiln against the naive command-line pipeline")
    w("")
    anchors = load("anchors.json")
    if anchors:
        anchors_subsection(w, anchors, load("anchors_2026-11-26.json"))
    f = r["funnel"]
    w(f"Pack `{r['pack']}`: {r['variants']} variants. The naive pipeline is what a shell loop over `kiln list --json`")
    w("does for every (variant, stage): `glslangValidator -D -V` (HLSL to SPIR-V, legalized), `spirv-opt -O`,")
    w("`spirv-val`, then `spirv-cross` three times (GLSL 450, GLSL ES 310, MSL): "
      f"{r['naive_stage_compiles']} stage compiles. Each configuration ran {r['reps']} times, interleaved")
    w(f"round-robin so that machine noise hits all alike (run of {r['date']}).")
    w("")
    w("| configuration | median | range | vs naive serial | vs naive parallel |")
    w("|---|---|---|---|---|")
    for name, values in samples.items():
        m = med[name]
        w(f"| {name} | {fmt_s(m)} | {fmt_s(min(values))} - {fmt_s(max(values))} | {naive_serial / m:.1f}x | {naive_parallel / m:.1f}x |")
    w("")
    w(f"- **Cold build: {naive_serial / cold:.1f}x faster** than the naive serial loop and "
      f"{naive_parallel / cold:.1f}x faster than the same loop run {jobs}-wide with `xargs`. "
      f"With one worker, kiln is {naive_serial / cold1:.1f}x faster than the serial loop.")
    glibc_name = f"kiln cold -j{jobs}, glibc malloc"
    if glibc_name in med:
        w(f"- **mimalloc**: the same kiln built with `-DKILN_MIMALLOC=OFF` (glibc's malloc) takes {fmt_s(med[glibc_name])}: "
          f"mimalloc makes the cold build {med[glibc_name] / cold:.2f}x faster"
          + (", with byte-identical packs (compared by the benchmark)." if r.get("glibc_pack_identical")
             else "; **the packs differ** (compared by the benchmark)."))
    floor_name = "library floor, one process"
    floor = med.get(floor_name)
    side_by_side = med.get(f"library floor, {jobs} processes side by side")
    if floor:
        ideal = (side_by_side or floor) / jobs
        runs = r.get("floor_runs") or [{}]
        w(f"- **Library floor: {fmt_s(floor)}** of glslang, SPIRV-Tools and SPIRV-Cross calls in one process "
          f"({runs[-1].get('front_ends', '?')} front ends, {runs[-1].get('back_ends', '?')} back ends, each once, nothing of")
        w(f"  kiln's own; `kiln-compile-steps --floor`, interleaved with the builds above)" + (
          f"; {jobs} copies side by side, one\n  per core, take {fmt_s(side_by_side)} in all "
          f"({floor / side_by_side:.0%} of perfect scaling)." if side_by_side else "."))
        w(f"  On {jobs} cores an ideal build with kiln's recipe and dedupe takes {fmt_s(ideal)}"
          + (f" (the side-by-side time / {jobs})" if side_by_side else f" (the floor / {jobs})")
          + f", {naive_serial / ideal:.1f}x faster than the naive serial loop: the")
        w(f"  most any kiln could reach in this run without changing the compile recipe. kiln's cold build is "
          f"{fmt_s(cold - ideal)} ({(cold - ideal) / cold:.0%})")
        stage = {name: float(v) * (1 if unit == "ms" else 1000) for name, v, unit in
                 re.findall(r"(preprocess|cache store|pack) ([0-9.]+) (ms|s)\b", r.get("kiln_summary", ""))}
        serial = ", ".join(f"{name} {fmt_s(stage[name] / 1000)}" for name in ("preprocess", "cache store", "pack") if name in stage)
        w("  above it: the stages outside the workers (in the instrumented run below: " + (serial or "see below")
          + "; preprocessing is work the floor")
        w("  does not count), the main process's share of the cores while the workers run (decoding results, dedupe,")
        w("  cache lookups), and the workers' job messages; the spread of the cold runs is as large.")
    met = "met" if naive_serial / cold >= 10 else "**not met**"
    w(f"- Target 10x: {met} (measured {naive_serial / cold:.1f}x). Where the rest goes: the funnel removes the")
    w("  duplicate compiles (and the module dedupe the duplicate back ends), kiln removes ~10 process start-ups per")
    w("  stage, and mimalloc the allocator overhead; what remains is SPIR-V legalization and optimization inside")
    w("  SPIRV-Tools, the same library passes the naive loop runs (table below: "
      + (f"{steps_share:.0%} of a fragment compile" if steps_share else "most of a compile") + ").")
    w("  Legalization already runs kiln's core recipe (the table below; SPIRV-Tools' full one only as a fallback),")
    w("  which leaves -O's output the same instruction for instruction. Beyond the floor, only a lighter")
    w("  optimization recipe than `spirv-opt -O` would help, i.e. different output from the pipeline it is compared")
    w("  with; kiln does not do that.")
    fc = r.get("file_create_ms")
    if fc is not None:
        w(f"- **File creation** costs {fc:.2f} ms per file in this machine's temporary directory (measured by the")
        w("  benchmark: 500 files; at other hours of the same day up to 1.3 ms). The naive loop creates 5 files per stage")
        w("  compile; kiln's cache writes one segment file per build (the `cache store` time in the stage times below),")
        w("  where it wrote one file per entry, 2,698 for this pack, before.")
    nc = med["kiln no-change rebuild"]
    w(f"- **No-change rebuild: {fmt_s(nc)}** (target: under 100 ms: {'met' if nc < 0.1 else '**not met**'}): the stamp")
    w("  written with the pack matches the inputs hash, so nothing is preprocessed, compiled or read.")
    code_name, comment_name = "kiln after a code edit in Fog.hlsl", "kiln after a comment edit in Fog.hlsl"
    if code_name in med and comment_name in med:
        w(f"- **Edits**: changing FOG_LINEAR's code in `shaderlib/Fog.hlsl` rebuilds in {fmt_s(med[code_name])} (only the")
        w(f"  FOG_LINEAR modules go through the back end); a comment and an unused function there, in {fmt_s(med[comment_name])}")
        w("  (front ends only: no reachable code changed, every back end comes from the cache).")
    w("")
    w("Funnel of the default pack:")
    w("")
    modules = f.get("unique_modules")
    w("| declared | valid (constraints) | kept (materials, scenes) | stage variants | unique per stage | compiles | "
      + ("front-end modules | " if modules is not None else "") + "unique binaries |")
    w("|---|---|---|---|---|---|" + ("---|" if modules is not None else "") + "---|")
    w(f"| {f['declared']} | {f['valid']} | {f['kept']} | {f['stage_instances']} | {f['unique_preprocessed']} | "
      f"{f['unique_compiles']} | " + (f"{modules} | " if modules is not None else "") + f"{f['unique_binaries']} |")
    w("")
    w("Cold build, stage times (one instrumented run; `compiled` counts front ends, `back ends` the distinct modules):")
    w("")
    w("```")
    w(r["kiln_summary"].strip())
    w("```")
    w("")
    edits = r.get("edit_summaries", {})
    for kind, caption in (("code", "After a code edit in FOG_LINEAR's branch of `shaderlib/Fog.hlsl` (included only by the fog variants):"),
                          ("comment", "After a comment and an unused function added to `shaderlib/Fog.hlsl`:")):
        if kind in edits:
            w(caption)
            w("")
            w("```")
            w(edits[kind].strip())
            w("```")
            w("")
    w(f"Peak resident memory of the largest process (kiln or a worker) over the run: {r['peak_child_rss_mib']} MiB.")
    w("")
    steps = [(kind, load(f"compile_steps_{kind}.json")) for kind in ("fragment", "vertex")]
    steps = [(kind, c) for kind, c in steps if c]
    if steps:
        w("### Where one compile's time goes")
        w("")
        w("`kiln-compile-steps` runs the steps of one compile job, in a worker's order and with its allocator ("
          + steps[0][1]["allocator"] + "), on the largest preprocessed Forward sources of the default pack; medians of "
          + str(steps[0][1]["repetitions"]) + " runs. `optimize (-O)` is exactly `spirv-opt -O`'s recipe. `legalize (core")
        w("recipe)` is the first sixteen passes of SPIRV-Tools' HLSL legalization recipe (inlining, scalar replacement,")
        w("SSA); the full recipe's remaining passes (CCP, loop unrolling, simplification...) are in -O anyway, and it")
        full = re.search(r"full legalizations (\d+)", r.get("kiln_summary", ""))
        w("runs only when the core recipe's result does not validate"
          + (f" ({full.group(1)} of the default pack's modules in the cold build above)" if full else "")
          + ". The naive loop's `glslangValidator` runs glslang's own list of the same kind of passes.")
        w("")
        w("| step | " + " | ".join(f"{kind} (ms)" for kind, _ in steps) + " |")
        w("|---|" + "---|" * len(steps))
        for i, row in enumerate(steps[0][1]["steps"]):
            w(f"| {row['step']} | " + " | ".join(f"{c['steps'][i]['median_ms']:.2f}" for _, c in steps) + " |")
        w("| **total** | " + " | ".join(f"**{c['total_ms']:.1f}**" for _, c in steps) + " |")
        if all("full_legalization_ms" in c for _, c in steps):
            w("| legalize, SPIRV-Tools' full recipe (the fallback; not in the total) | "
              + " | ".join(f"{c['full_legalization_ms']:.2f}" for _, c in steps) + " |")
        w("| SPIR-V words: front end, legalized, optimized | " + " | ".join(
            f"{c['spirv_words']['front_end']}, {c['spirv_words']['legalized']}, {c['spirv_words']['optimized']}" for _, c in steps) + " |")
        w("")
    runs = r.get("floor_runs")
    if runs:
        totals = {row["step"]: [] for row in runs[0]["steps"]}
        for run in runs:
            for row in run["steps"]:
                totals[row["step"]].append(row["total_s"])
        w("The library floor by step (`kiln-compile-steps --floor`: every stage source of the cold build once; back-end")
        w(f"steps once per distinct module; medians of the {len(runs)} interleaved runs above, single process):")
        w("")
        w("| step | runs | seconds |")
        w("|---|---|---|")
        counts = {row["step"]: row["runs"] for row in runs[0]["steps"]}
        for step, values in totals.items():
            w(f"| {step} | {counts[step]} | {statistics.median(values):.2f} |")
        w("")


def scaling_section(w, s):
    w("### Growth with the number of keywords")
    w("")
    w(f"A synthetic shader with K fragment keywords (each changing the code) has 2^K variants; `bench/scaling.py`")
    w(f"builds it cold with -j{s['jobs']} (all four targets) and times planning alone (`kiln list`) further up.")
    w("")
    w("| keywords | variants | plan (kiln list) | cold build | per variant | unique binaries |")
    w("|---|---|---|---|---|---|")
    built = []
    for row in s["rows"]:
        if "build_s" in row:
            built.append(row)
            w(f"| {row['keywords']} | {row['variants']} | {fmt_s(row['plan_s'])} | {fmt_s(row['build_s'])} | "
              f"{row['build_s'] / row['variants'] * 1000:.1f} ms | {row['funnel']['unique_binaries']} |")
        else:
            w(f"| {row['keywords']} | {row['variants']} | {fmt_s(row['plan_s'])} | (not built) | | |")
    w("")
    if len(built) >= 2:
        a, b = built[-2], built[-1]
        w(f"Build time grows linearly with the number of distinct variants (doubling from {a['variants']} to "
          f"{b['variants']} variants took {b['build_s'] / a['build_s']:.2f}x the time); planning stays far below the")
        w("compile time even at the largest plans, because counting and stripping happen before expansion.")
        w("")
    data = "\n".join(f"{row['variants']} {row['build_s']}" for row in built)
    plan = "\n".join(f"{row['variants']} {row['plan_s']}" for row in s["rows"])
    gnuplot(f"""set terminal pngcairo size 720,420
set output '{PLOTS}/scaling.png'
set logscale xy
set xlabel 'variants (2^K)'
set ylabel 'seconds'
set key top left
set grid
plot '-' using 1:2 with linespoints title 'cold build', '-' using 1:2 with linespoints title 'planning (kiln list)'
{data}
e
{plan}
e
""")
    w("![build time against variants](plots/scaling.png)")
    w("")


def study_section(w, st):
    w("## 2. Shading cost against error")
    w("")
    w(f"Every term below was compiled by kiln's front end and SPIRV-Tools (`tests/gpu/Probe.hlsl`, one `TERM_*` per")
    w(f"probe) and **run on {st['device']}** over a dense grid; its output was read back and compared with the")
    w("double-precision CPU reference (`verify/reference`): the exact formula, or Monte-Carlo ground truth for the")
    w("environment BRDF and the white furnace. fp16 rows are explicit 16-bit variants (`_HALF_PRECISION`), measured")
    w("where roughness >= 0.089 (below it they clamp to a different lobe by design).")
    w("")
    w(f"**Cost** is the weighted instruction count of the optimized SPIR-V minus the empty probe's. Weights: "
      f"{st['cost_weights']}. Lavapipe time (2^20 evaluations, median of 9, minus the empty probe) is a secondary")
    w("axis only: it varies 5-34% run to run on this machine and is never used to rank differences under 30%.")
    w("Relative errors use the reference value as denominator; the DFG and furnace errors are absolute (albedo units).")
    w("")
    notes = {
        "Light falloff (range 20 m)": "The window is meant to deviate: it brings the light to exactly 0 at its range "
        "(the max error is at 19 m); at half the range it is 12% below the inverse-square law. Seed 002's literal "
        "`+1` form is 2x too dark at 1 m and 99% too dark at 10 cm, which is why shaderlib floors the distance at "
        "1 cm instead.",
        "Multiscatter (white furnace)": "Energy of a white (f0 = 1) surface lit by a white furnace: the Monte-Carlo "
        "single-scattering albedo (65536 samples) times the compensation factor the GPU computed from the table, "
        "NoV 0.1-1. Without compensation up to 69% of the energy is lost at roughness 1. As above, these rows are "
        "from the study's run on the tables of that date; section 4 has the current table at grazing NoV.",
        "Environment BRDF (split-sum DFG)": "E = lerp(dfg.x, dfg.y, f0) at f0 = 0.04 and 1, against the Monte-Carlo "
        "integrals at the grid points (which fall between texels), NoV 0.05-1. The cost includes the lookup's coordinate "
        "remap (texels sit on the domain edges). These rows come from the study's run (date above), on the tables of "
        "that date (linear in NoV and roughness); section 4 measures the current table (cbrt(NoV) columns) down to "
        "NoV = 0.005, where the linear table was off by up to 0.09.",
        "Additional lights: Forward+ vs plain loop": "128 point lights (range 1 m) over a 6.4 m ground patch seen as "
        "128x128 pixels; Forward+ reads conservative per-tile lists (16x16 pixels) built on the CPU. The cost column "
        "is the loop's code (one iteration plus setup); per pixel it runs once per light evaluated, given in the note. "
        "Lavapipe time here is measured on the whole patch and is the meaningful axis (a large effect).",
        "Additional lights: per vertex vs per pixel": "One triangle (edge 0.25 m and 1 m) under a point light 0.5-4 m "
        "above it. Per-vertex lighting moves the light evaluation to the vertex stage; its fragment cost is applying "
        "the interpolated value. Its error grows as the light gets closer than the triangle is large.",
    }
    summary = {}
    for fam in st["families"]:
        w(f"### {fam['name']}")
        w("")
        w(f"Ground truth: {fam['truth']}; {fam['points']} grid points; error {fam['error_kind']}.")
        if fam["name"] in notes:
            w(notes[fam["name"]])
        w("")
        w("| variant | cost | texture fetches | lavapipe ms (spread) | max error | mean error | note |")
        w("|---|---|---|---|---|---|---|")
        for m in fam["members"]:
            summary[m["name"]] = m
            note = m["note"]
            if "lights_per_pixel" in m:
                note += f"; {m['lights_per_pixel']:.1f} lights evaluated per pixel"
            w(f"| {m['name']} | {m['cost']:.0f} | {m['texture_fetches']} | {m['gpu_ms']:.2f} ({m['gpu_spread'] * 100:.0f}%) | "
              f"{fmt_e(m['max_error'])} | {fmt_e(m['mean_error'])} | {note} |")
        w("")
        name = slug(fam["name"])
        rows = "\n".join(f"{m['cost']} {max(m['max_error'], 1e-9)} \"{m['name']}\"" for m in fam["members"])
        gnuplot(f"""set terminal pngcairo size 760,440 font ',9'
set output '{PLOTS}/{name}.png'
set title "{fam['name']}: cost vs max error"
set xlabel 'weighted SPIR-V instructions (minus empty probe)'
set ylabel 'max {fam['error_kind']} error'
set logscale y
set grid
set offsets graph 0.05, graph 0.35, graph 0.1, graph 0.1
unset key
plot '-' using 1:2 with points pt 7 ps 1.2, '-' using 1:2:3 with labels left offset 0.8,0.4 font ',8'
{rows}
e
{rows}
e
""")
        w(f"![{fam['name']}](plots/{name}.png)")
        w("")
    return summary


def targets_section(w, summary):
    w("### Targets of the study")
    w("")
    exact = ["D_GGX fp32", "V_SmithGGXCorrelated fp32", "F_Schlick (multiply chain) fp32", "Fd_Lambert fp32",
             "Fd_Burley fp32", "Fd_RenormalizedBurley fp32"]
    w("| target | measured | status |")
    w("|---|---|---|")
    for name in exact:
        if name in summary:
            e = summary[name]["max_error"]
            w(f"| {name} within 2e-4 relative of the double reference | max {fmt_e(e)} | {'met' if e <= 2e-4 else '**not met**'} |")
    furnace = summary.get("compensation, DFG table 64x64 float")
    if furnace:
        e = furnace["max_error"]
        w(f"| white furnace, multiscatter + 64x64 table, within 1% of 1 (roughness 0.045-1, NoV 0.1-1 only; "
          f"grazing NoV in section 4) | max {e * 100:.2f}% | {'met' if e <= 0.01 else '**not met**'} |")
    w("")


def recommendations(w, summary):
    def get(name):
        return summary.get(name, {})

    w("### Recommended defaults per quality tier")
    w("")
    w("Read off the tables above (cost first, then error), for the library's keyword choices:")
    w("")
    v_fast, v_exact = get("V_SmithGGXCorrelated_Fast fp32"), get("V_SmithGGXCorrelated fp32")
    env_approx, t64_16 = get("EnvBRDFApprox fp32"), get("DFG table 64x64, 16-bit unorm")
    t32_8 = get("DFG table 32x32, 8-bit unorm")
    w("| tier | visibility | environment BRDF | multiscatter | diffuse | precision |")
    w("|---|---|---|---|---|---|")
    w(f"| high (desktop) | exact correlated Smith (max error {fmt_e(v_exact.get('max_error', 0))}) | DFG table 64x64, 16-bit "
      f"(max {fmt_e(t64_16.get('max_error', 0))}) | on (`_MULTISCATTER`) | renormalized Burley | fp32 |")
    w(f"| medium | exact correlated Smith: the fast form saves {v_exact.get('cost', 0) - v_fast.get('cost', 0):.0f} weighted "
      f"instructions for a {fmt_e(v_fast.get('max_error', 0))} max error | DFG table 32x32, 8-bit (max "
      f"{fmt_e(t32_8.get('max_error', 0))}) | on | Lambert | fp32 |")
    w(f"| low (mobile) | fast form | EnvBRDFApprox (no texture fetch; max error {fmt_e(env_approx.get('max_error', 0))}) | off "
      "(needs the table) | Lambert | fp16 (`_HALF_PRECISION`), lights pre-exposed |")
    w("")
    pixel = get("per pixel (_ADDITIONAL_LIGHTS)")
    fr, fp = get("F_Schlick (multiply chain) fp32"), get("F_Schlick_Pow fp32")
    w(f"Scale: one per-pixel point light's Lambert term alone costs {pixel.get('cost', 0):.0f}; the specular terms above")
    w("are paid once per light and per pixel, the environment BRDF once per pixel. `F_Schlick` with the multiply")
    w(f"chain costs {fr.get('cost', 0):.0f} against {fp.get('cost', 0):.0f} for `pow` at the same accuracy "
      f"({fmt_e(fr.get('max_error', 0))} vs {fmt_e(fp.get('max_error', 0))}): keep the chain everywhere. fp16 rows")
    w("cost more here because the count includes the fp16/fp32 conversions glslang inserts around intrinsics and")
    w("does not model packed fp16 arithmetic, which is where fp16 saves time on mobile GPUs.")
    w("")


def stress_section(w, s):
    w("## 3. Numerical stress test (`ctest -L stress`, a gate in CI)")
    w("")
    w(f"Run on {s['device']}. Every public function of the library and the full lit shading (one light plus IBL,")
    w("through `PrepareShading`, `AccumulateLight`, `IndirectLighting`, in each shading model) over grids of 5,000+")
    w("points with the special cases: roughness 0 and 1e-8; NoV, NoL 0 and 1e-8; NoH 1 and 1 - 1 ulp; light distance")
    w("0; zero-length normal, view and light vectors; equal spot angles; intensities and tone-map inputs up to 1e5;")
    w("anisotropy +-1. The gate is zero NaN, Inf and negative outputs in fp32 and in explicit fp16.")
    w("")
    w("| probe | points | fp32 NaN / Inf / negative | fp16 NaN / Inf / negative |")
    w("|---|---|---|---|")
    for g in s["gates"]:
        a, b = g["fp32"], g["fp16"]
        w(f"| {g['probe']} | {g['points']} | {a['nan']} / {a['inf']} / {a['negative']} | {b['nan']} / {b['inf']} / {b['negative']} |")
    t = s.get("textbook")
    if t:
        w(f"| *unguarded textbook Cook-Torrance (must fail)* | {t['points']} | {t['fp32']['nan']} / {t['fp32']['inf']} / "
          f"{t['fp32']['negative']} | {t['fp16']['nan']} / {t['fp16']['inf']} / {t['fp16']['negative']} |")
    w("")
    w("The last row is the sensitivity check: the same harness finds thousands of NaN/Inf in the textbook kernel, and")
    w("the test asserts that it does. When first run, the gate (and its fp16 accuracy table) found four real defects,")
    w("all fixed in shaderlib: fp16 radiance sums and casts of 1e5 lux overflowing to Inf; D*V overflowing fp16 before")
    w("F brought it back in range; the anisotropic lobe collapsing in fp16 (a 3e5 relative error); EnvBRDFApprox")
    w("returning -0.0024 at f0 = 0. A fifth, `saturateMediump` clamping fp32 values at 65504, was found while fixing them.")
    w("")
    w("### Where fp16 loses accuracy")
    w("")
    w("Relative error of the fp16 variant against the fp32 variant, over the safe range (roughness above the fp16")
    w("floor of 0.089 including the anisotropic axis, NoV and NoL >= 1e-3 (grazing included), non-degenerate vectors, illuminance <= 1e3")
    w("as a pre-exposed fp16 renderer sees it, fp32 value within fp16's range); magnitudes below 1e-3 count as 1e-3.")
    w("")
    w("| probe | output | points | mean | 99th percentile | max |")
    w("|---|---|---|---|---|---|")
    for g in s["gates"]:
        for l in g["fp16_loss"]:
            if l["max"] == 0:
                continue
            w(f"| {g['probe']} | {l['output']} | {g['fp16_loss_points']} | {fmt_e(l['mean'])} | {fmt_e(l['p99'])} | {fmt_e(l['max'])} |")
    w("")
    w("Outputs with zero error are computed in fp32 in every variant (light attenuation, color temperature, ACES) and")
    w("are omitted. The largest losses: renormalized Burley and EnvBRDFApprox (~1% at the 99th percentile). The")
    w("anisotropic lit path lost up to 73% here while D*V*F and each light's radiance were clamped at 65504 in fp16 (issue 23); with")
    w("BRDF x NoL kept in fp32 it is at the level of the other models. PROBE_DIRECT excludes, like every row, the points")
    w("whose fp32 value exceeds 65504; section 4 measures the energy of the whole lobe, those points included.")
    w("")


def accuracy_section(w, a):
    w("## 4. Accuracy gate (`ctest -L stress`, `stress.Accuracy.*`)")
    w("")
    w(f"Run on {a['device']} by `tests/stress/accuracy_test.cpp`. Every public BRDF term (`BRDF.hlsl`), light function")
    w("(`Lights.hlsl`), IBL helper (`SampleSH9`, `EnvBRDFApprox`, `SpecularDFG`, `EnergyCompensation`, `SampleDFG` below),")
    w("`ACESFitted` and `DirectBRDF` runs on lavapipe over a dense grid of its valid domain (roughness from the precision's")
    w("floor, NoV and NoL from 1e-3, NoH up to 1) and is compared with the double-precision CPU reference (`verify/reference`)")
    w("under the bound stated in the test; relative error, magnitudes below 1e-3 (SH: 1e-2) counted as 1e-3. fp16 rows")
    w("start at the fp16 roughness floor (0.089). Not covered here: `BoxProjectedDirection`, `IndirectLighting`, the fog")
    w("and shadow-map functions (they are exercised by the golden images only).")
    w("")
    w("| term | precision | points | mean | max | bound |")
    w("|---|---|---|---|---|---|")
    for t in a.get("terms", []):
        w(f"| {t['term']} | {t['precision']} | {t['points']} | {fmt_e(t['mean'])} | {fmt_e(t['max'])} | {fmt_e(t['bound'])} |")
    w("")
    d = a.get("direct_energy")
    if d:
        w("### Energy of the direct specular lobe in fp16")
        w("")
        w(f"Directional albedo of `DirectBRDF` (BRDF x NoL per unit illuminance) integrated over L on lavapipe with the same")
        w(f"{d['samples_per_cell']} GGX-sampled directions per cell for fp32 and fp16, roughness 0.089-1, NoV 1e-3-1. Target")
        w("(issue 23): fp16 within 2% of fp32. Before the fix, `DirectBRDF` clamped D*V*F*(compensation) at 65504 before")
        w("multiplying by NoL and lost up to 69% of the albedo at grazing NoV; it now returns BRDF x NoL in fp32.")
        w("")
        w("| keywords | max relative difference, fp16 vs fp32 (metal and dielectric) | AccumulateLight (metal, 1 lux) |")
        w("|---|---|---|")
        for k, v in d["keywords"].items():
            w(f"| {k} | {fmt_e(v['max_relative_fp16_vs_fp32'])} | {fmt_e(v['max_relative_accumulate_fp16_vs_fp32'])} |")
        w("")
        w(f"The fp32 energy against the double reference at the same points: max relative difference {fmt_e(d['max_relative_fp32_vs_double'])}.")
        w("Before the fix, the same test (on 8590f21) measured fp16 / fp32 - 1 = -0.60, -0.67, -0.67, -0.42, -0.08 at")
        w("NoV = 0.003, 0.01, 0.02, 0.05, 0.1 (roughness 0.089, `_MULTISCATTER`); worst -0.67. The energies below are")
        w("estimates from 2048 samples (about 1% noise of their own, which is why they straddle 1); fp32 and fp16 share")
        w("the samples, so their ratio is not affected.")
        w("")
        w("| roughness | NoV | energy fp32 (`_MULTISCATTER`, f0 = 1) | energy fp16 | fp16 / fp32 - 1 |")
        w("|---|---|---|---|---|")
        for c in d["cells"]:
            if c["NoV"] in (1e-3, 3e-3, 0.01, 0.05, 0.1, 1.0) and c["roughness"] in (0.089, 0.1, 0.2, 0.6, 1.0):
                w(f"| {c['roughness']} | {c['NoV']:g} | {c['energy_fp32']:.4f} | {c['energy_fp16']:.4f} | "
                  f"{c['energy_fp16'] / c['energy_fp32'] - 1:+.2e} |")
        w("")
    l = a.get("dfg_lookup")
    f = a.get("white_furnace")
    if d and l and f:
        w("### Targets (issue 23)")
        w("")
        w("| target | measured | status |")
        w("|---|---|---|")
        e16 = max(v["max_relative_fp16_vs_fp32"] for v in d["keywords"].values())
        w(f"| fp16 direct specular energy within 2% of fp32 (roughness 0.089-1, NoV 1e-3-1) | max {100 * e16:.2f}% | "
          f"{'met' if e16 <= 0.02 else '**not met**'} |")
        el = max(l[p]["max_abs_albedo_error"] for p in ("fp32", "fp16"))
        w(f"| DFG lookup within 0.005 of the integral, NoV >= 0.005, every roughness | max {el:.4f} | "
          f"{'met' if el <= 0.005 else '**not met**'} |")
        ef = max(f[p]["max_abs_energy_error_nov_from_0.01"] for p in ("fp32", "fp16"))
        w(f"| `_MULTISCATTER` white furnace within 1%, NoV >= 0.01 | max {100 * ef:.2f}% | "
          f"{'met' if ef <= 0.01 else '**not met**'} |")
        w("")
    if l and f:
        w("### DFG table at grazing angles")
        w("")
        w("The shipped table (`shaderlib/data/dfg64.kdfg`, 64x64, columns spaced in sqrt(NoV)) looked up on lavapipe")
        w("through `SampleDFG`, against `DFGQuadrature`, an integrator that is not the table's generator (a midpoint")
        w("product rule over the half vectors with Smith's Lambda, instead of GGX importance sampling; checked against")
        w("E(mu) = 1 - mu ln(1 + 1/mu) at alpha = 1 in `unit.Reference.*`), at every roughness row and halfway between")
        w(f"rows, {l['points']} points with NoV from 0.005 to 1. Directional albedo error at f0 = 0, 0.04 and 1:")
        w("")
        w("| precision | max absolute albedo error (NoV >= 0.005) | bound | white furnace with `_MULTISCATTER`, NoV >= 0.01 | NoV 0.005-0.01 |")
        w("|---|---|---|---|---|")
        for p in ("fp32", "fp16"):
            w(f"| {p} | {fmt_e(l[p]['max_abs_albedo_error'])} | {fmt_e(l[p]['bound'])} | "
              f"{100 * f[p]['max_abs_energy_error_nov_from_0.01']:.2f}% | {100 * f[p]['max_abs_energy_error_nov_0.005_to_0.01']:.2f}% |")
        w("")
        w("With the previous table (64 columns linear in NoV) the same lookup was off by up to 0.089 and the white furnace")
        w("by -9.0% at NoV = 0.003 (issue 23).")
        w("")


def frame_cost_section(w, f):
    w("## 5. Additional lights inside rendered frames")
    w("")
    w(f"Run on {f['device']} ({f['date']}) by `build/ci/bench/kiln-frame-cost` with the default pack: the whole Forward")
    w("pass of a scene drawn on lavapipe (pipelines and shadow maps made before), median of "
      f"{f['scenes'][0]['frames']} draws; error against the CPU reference shading the same G-buffer in double (the")
    w("per-vertex row against the full per-pixel shading of every light, so its error is what that keyword gives up).")
    w("Lavapipe runs the shaders on the CPU; the ratios, not the milliseconds, carry over to GPUs.")
    w("")
    for sc in f["scenes"]:
        w(f"### {sc['scene']}: {int(sc['lights'])} additional lights, {sc['size'][0]}x{sc['size'][1]}")
        w("")
        w("| variant | draw ms (min-max) | lights per pixel | relative RMSE | pixels over 2/255 | note |")
        w("|---|---|---|---|---|---|")
        for v in sc["variants"]:
            lp = f"{v['lights_per_pixel']:.1f}" if v["lights_per_pixel"] else "-"
            w(f"| {v['name']} | {v['draw_ms_median']:.1f} ({v['draw_ms_min']:.1f}-{v['draw_ms_max']:.1f}) | {lp} | "
              f"{fmt_e(v['relative_rmse'])} | {100 * v['fraction_over_2']:.2f}% | {v['note']} |")
        w("")
    night = {v["name"]: v for v in f["scenes"][0]["variants"]}
    plain = next(v for k, v in night.items() if k.startswith("plain"))
    tiled = next(v for k, v in night.items() if k.startswith("Forward+"))
    vertex = next(v for k, v in night.items() if k.startswith("per vertex"))
    base = next(v for k, v in night.items() if k.startswith("no additional"))
    w(f"With {int(f['scenes'][0]['lights'])} lights, Forward+ draws the frame in {tiled['draw_ms_median']:.1f} ms against "
      f"{plain['draw_ms_median']:.1f} ms for the plain loop ({plain['draw_ms_median'] / tiled['draw_ms_median']:.1f}x), "
      f"visiting {tiled['lights_per_pixel']:.1f} lights per pixel instead of {plain['lights_per_pixel']:.0f}, with the same")
    w(f"error. Per-vertex lighting costs {vertex['draw_ms_median']:.1f} ms (the frame without additional lights: "
      f"{base['draw_ms_median']:.1f} ms) but its error is {fmt_e(vertex['relative_rmse'])} relative RMSE with "
      f"{100 * vertex['fraction_over_2']:.0f}% of the pixels visibly off: it evaluates at most 8 lights, Lambert only, at the")
    w("vertices (as URP does), a fallback for a few large lights, not for hundreds of small ones.")
    w("")


def remote_cache_section(w, r):
    m = r["medians"]
    w("## 5. The remote cache on loopback")
    w("")
    w(f"`bash bench/remote_cache.sh build/ci/compiler/kiln . {r['rounds']}` ({r['date']}): Debian's nginx with WebDAV PUT on")
    w("127.0.0.1, the default pack (`variants/lit.pack.json`), every build from an empty local cache and output directory")
    w(f"unless said otherwise; medians of {r['rounds']} interleaved runs (s). A second checkout at another path has another")
    w("inputs hash, so it reads the per-source entries; one at the same path reads the pack-level entry.")
    if r.get("conditions"):
        w(r["conditions"])
    w("")
    w("| build | median s | runs (s) | vs cold |")
    w("|---|---|---|---|")
    names = {"cold": "cold (no remote)", "remote_sources": "second client, warm from the remote (per stage source)",
             "remote_pack": "second client, same path (pack-level entry)", "local_warm": "warm local cache, no remote",
             "local_warm_remote_down": "warm local cache, remote down (connection refused)"}
    for key, label in names.items():
        runs = ", ".join(f"{x:.2f}" for x in r["seconds"][key])
        w(f"| {label} | {m[key]:.2f} | {runs} | {m['cold'] / m[key]:.1f}x |")
    w("")
    w(f"- Upload (cold, `--remote-upload`): {r['upload']}")
    w(f"- Per-source fetch: {r['per_source']['requests']} requests; {r['per_source']['summary']}")
    w(f"- Pack-level fetch: {r['pack_level']['requests']} requests; " + r['pack_level']['summary'].replace(chr(10), "; "))
    w(f"- After an include edit (a constant of `Fog.hlsl`, read from the remote filled before it): {r['include_edit'].rstrip(';')}")
    t = load("remote_transfers.json")
    if t:
        counts = sorted({row["transfers"] for row in t["rows"]})
        servers = list(dict.fromkeys(row["server"] for row in t["rows"]))
        cell = {(row["server"], row["transfers"]): row["median_fetch_s"] for row in t["rows"]}
        w(f"- Parallel transfers (threads, one kept-alive libcurl handle each), per-source fetch of checkout b (the pack-level")
        w(f"  entry misses), medians of {t['rounds']} interleaved rounds, {t['date']} (`python3 bench/remote_transfers.py`): the")
        w(f"  fetch (the build's compile stage, where nothing is compiled) by `--remote-transfers`, directly against nginx on")
        w(f"  loopback and through a proxy that delays every request by {t['delay_ms']:g} ms (no netem on this machine):")
        w("")
        w("  | in flight | " + " | ".join(str(c) for c in counts) + " |")
        w("  |---|" + "---|" * len(counts))
        for server in servers:
            w(f"  | {server} | " + " | ".join(f"{cell[(server, c)]:.2f} s" for c in counts) + " |")
        w("")
        w("  On loopback the fetch is CPU-bound; with latency it scales with the requests in flight until it meets the")
        w("  loopback floor. Threads reach these counts (the default is 32), so libcurl's multi interface, which would hold as")
        w("  many on one thread, would not make the build measurably faster; kiln keeps the threads (docs/remote-cache.md).")
    w(f"- Server: {r['server']['objects']} objects, {r['server']['bytes']} bytes. A remote that is down costs "
      f"{m['local_warm_remote_down'] - m['local_warm']:+.2f} s here (refused at once); an unreachable host costs at most "
      "the connect timeout (1 s by default), once: then the remote is off for the build.")
    w("")


def main():
    os.makedirs(PLOTS, exist_ok=True)
    lines = []
    w = lines.append
    speed = load("build_speed.json")
    scaling = load("scaling.json")
    study = load("shading_study.json")
    stress = load("stress.json")
    accuracy = load("accuracy.json")
    frame_cost = load("frame_cost.json")
    remote = load("remote_cache.json")
    w("# kiln benchmarks: generated tables")
    w("")
    w("Written by `bench/report.py`, the last step of `bash bench/run_all.sh` (about 95 minutes on 2 cores), from")
    w("`bench/results/*.json`. bench/REPORT.md, the reference ordered by topic, takes its current figures from here.")
    w("Every number below comes from a run on this machine, at the dates given.")
    w("")
    if speed:
        w(f"- Machine: {speed['machine']['cpus']} cores, {speed['machine']['memory_gib']} GiB, {speed['machine']['platform']}.")
        w(f"- Tools: {speed['tools']['frontend']}, SPIRV-Tools {speed['tools']['spirv_tools']}, SPIRV-Cross {speed['tools']['spirv_cross']}"
          + (f"; {study['device']}" if study else "") + ".")
        w(f"- Date: {speed['date']}" + (f" (shading study {study['date']})" if study else "") + ".")
        for line in LATER_NOTES:
            w(line)
    w("")
    if speed:
        build_speed_section(w, speed)
    if scaling:
        scaling_section(w, scaling)
    summary = {}
    if study:
        summary = study_section(w, study)
        targets_section(w, summary)
        recommendations(w, summary)
    if stress:
        stress_section(w, stress)
    if accuracy:
        accuracy_section(w, accuracy)
    if frame_cost:
        frame_cost_section(w, frame_cost)
    if remote:
        remote_cache_section(w, remote)
    os.makedirs(RESULTS, exist_ok=True)
    open(os.path.join(RESULTS, "REPORT.generated.md"), "w").write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
