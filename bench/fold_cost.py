#!/usr/bin/env python3
"""What folding keywords saves and costs (docs/keywords.md, REPORT section 15): for a pack and the keywords to fold,
kiln builds the pack as it is, with every named group folded into specialization constants, into dynamic branches,
and with one group folded at a time; cold builds, rounds interleaved, medians: wall time, modules, pack size. Then
the run-time cost on lavapipe (kiln-fold-cost): the same variants drawn from the variant, dynamic-branch and
specialization-constant packs, interleaved, with a recommendation per keyword.

The build half works on any pack. The run-time half draws with kiln's verify renderer, which feeds the resources
of shaderlib/'s passes: it runs for packs of the bundled library (--no-frames leaves it out).

usage: python3 bench/fold_cost.py --kiln build/ci/compiler/kiln [--fold-cost build/ci/bench/kiln-fold-cost]
           [--pack variants/lit.pack.json] [--fold _SHADOWS_SOFT --fold FOG_LINEAR,FOG_EXP,FOG_EXP2 ...]
           [--reps 3] [--frames 15] [--rounds 5] [--out bench/results/fold_cost.json]
"""
import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
THRESHOLD = 0.02  # run-time cost above which a keyword stays a variant


def absolute_definition(pack_file):
    """The pack definition with every path absolute, so that a copy elsewhere builds the same sources."""
    definition = json.load(open(pack_file))
    base = os.path.dirname(os.path.abspath(pack_file))
    definition.pop("$schema", None)
    definition["include_dirs"] = [os.path.join(base, d) for d in definition.get("include_dirs", [])]
    for p in definition["passes"]:
        if "source" in p:
            p["source"] = os.path.join(base, p["source"])
    return definition


def cold_build(kiln, definition_file, work):
    out = os.path.join(work, "out")
    shutil.rmtree(out, ignore_errors=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([kiln, "build", definition_file, "-o", os.path.join(out, "pack"), "--no-cache", "-q", "-j", "2"],
                   check=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    manifest = next(f for f in os.listdir(os.path.join(out, "pack")) if f.endswith(".manifest.json"))
    m = json.load(open(os.path.join(out, "pack", manifest)))
    kpack = os.path.join(out, "pack", m["archive"]["file"])
    return {"wall_s": wall, "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
            "modules": len(m["binaries"]), "pack_bytes": os.path.getsize(kpack)}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--fold-cost", help="kiln-fold-cost (the run-time half)")
    parser.add_argument("--pack", default=os.path.join(ROOT, "variants/lit.pack.json"))
    parser.add_argument("--fold", action="append",
                        help="one keyword group to fold, its keywords comma-separated (repeat per group; default: soft "
                             "shadows, the fog modes, multiscatter)")
    parser.add_argument("--scene", default=os.path.join(ROOT, "variants/scenes/render/spheres.json"))
    parser.add_argument("--base", default="_MAIN_LIGHT_SHADOWS",
                        help="keywords every drawn variant holds (space-separated): a shadow map for soft shadows")
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--frames", type=int, default=15)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--no-frames", action="store_true")
    parser.add_argument("--out", default=os.path.join(ROOT, "bench/results/fold_cost.json"))
    args = parser.parse_args()
    kiln = os.path.abspath(args.kiln)
    groups = [g.split(",") for g in (args.fold or ["_SHADOWS_SOFT", "FOG_LINEAR,FOG_EXP,FOG_EXP2", "_MULTISCATTER"])]
    keywords = [k for g in groups for k in g]
    work = tempfile.mkdtemp(prefix="kiln-fold-cost-")
    try:
        base = absolute_definition(args.pack)

        def write(name, kinds):
            d = dict(base, name=name)
            if kinds:
                d["keyword_kinds"] = kinds
            path = os.path.join(work, name + ".pack.json")
            json.dump(d, open(path, "w"), indent=1)
            return path

        configs = {"variant": write("variant", {}),
                   "specialization_constant": write("specialized", {k: "specialization_constant" for k in keywords}),
                   "dynamic_branch": write("dynamic", {k: "dynamic_branch" for k in keywords})}
        for g in groups:
            configs["only " + " ".join(g)] = write("only_" + "_".join(g).strip("_"),
                                                   {k: "specialization_constant" for k in g})
        results = {name: [] for name in configs}
        for rep in range(args.reps):  # --reps 0: the run-time half only
            for name, path in configs.items():
                r = cold_build(kiln, path, os.path.join(work, "build-" + str(abs(hash(name)))))
                results[name].append(r)
                print(f"rep {rep + 1}/{args.reps} {name}: {r['wall_s']:.2f} s, {r['modules']} modules, "
                      f"{r['pack_bytes']} bytes", flush=True)
        med = lambda name, key: statistics.median(r[key] for r in results[name])
        builds = []
        for name in configs if args.reps else []:
            builds.append({"config": name, "wall_s": med(name, "wall_s"), "cpu_s": med(name, "cpu_s"),
                           "modules": results[name][0]["modules"], "pack_bytes": results[name][0]["pack_bytes"],
                           "wall_ratio_to_variant": med("variant", "wall_s") / med(name, "wall_s"),
                           "walls": [r["wall_s"] for r in results[name]]})
        out = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "pack": os.path.relpath(args.pack, ROOT),
               "fold": keywords, "groups": groups, "reps": args.reps, "load_average": open("/proc/loadavg").read().split()[0],
               "builds": builds}
        for b in builds:
            print(f"{b['config']}: {b['wall_s']:.2f} s ({b['wall_ratio_to_variant']:.2f}x faster than variants), "
                  f"{b['modules']} modules, {b['pack_bytes'] / 1e6:.2f} MB")

        if args.fold_cost and not args.no_frames:
            dirs = {}
            for kind in ("variant", "dynamic_branch", "specialization_constant"):
                d = os.path.join(work, "frames-" + kind)
                subprocess.run([kiln, "build", configs[kind], "-o", d, "--no-cache", "-q"], check=True)
                dirs[kind] = d
            base_keywords = args.base.split()
            rows = [{"name": "all folded keywords off", "keywords": base_keywords}]
            rows += [{"name": k + " on", "keywords": base_keywords + [k]} for k in keywords]
            # The variant pack twice: the second renderer's ratio to the first is the measurement's own noise (A/A).
            config = {"scene": args.scene, "frames": args.frames, "rounds": args.rounds,
                      "packs": [{"kind": k, "dir": dirs[k]} for k in ("variant", "dynamic_branch", "specialization_constant")]
                      + [{"kind": "variant again", "dir": dirs["variant"]}],
                      "rows": rows}
            config_file = os.path.join(work, "frames.json")
            json.dump(config, open(config_file, "w"))
            frames_out = os.path.join(work, "frames-out.json")
            subprocess.run([os.path.abspath(args.fold_cost), config_file, frames_out], check=True)
            frames = json.load(open(frames_out))
            # Each kind against the variant pack's two renderers pooled; a cost counts when it is above 2% and above
            # the A/A noise of the measurement (the largest difference between the two over the rows).
            def pooled(row):
                return (row["draw_ms_median"]["variant"] + row["draw_ms_median"]["variant again"]) / 2
            noise = max(abs(row["draw_ms_median"]["variant"] - row["draw_ms_median"]["variant again"]) / pooled(row)
                        for row in frames["rows"])
            frames["noise"] = noise
            for row in frames["rows"]:
                costs = {k: row["draw_ms_median"][k] / pooled(row) - 1 for k in ("dynamic_branch", "specialization_constant")}
                row["cost_against_pooled_variant"] = costs
                bar = max(THRESHOLD, noise)
                if costs["dynamic_branch"] <= bar:
                    row["recommendation"] = "dynamic_branch (no cost measured: one pipeline for every value)"
                elif costs["specialization_constant"] <= bar:
                    row["recommendation"] = (f"specialization_constant (a dynamic branch costs "
                                             f"{100 * costs['dynamic_branch']:.0f}%)")
                else:
                    row["recommendation"] = "variant (folding costs more than 2% and the noise)"
            out["frames"] = frames
            print(f"noise (the variant pack against itself): {100 * noise:.1f}%")
            for row in frames["rows"]:
                c = row["cost_against_pooled_variant"]
                print(f"{row['name']}: variant {pooled(row):.2f} ms, dynamic branch {100 * c['dynamic_branch']:+.1f}%, "
                      f"specialization constant {100 * c['specialization_constant']:+.1f}% -> {row['recommendation']}")
        os.makedirs(os.path.dirname(args.out), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(out, f, indent=2)
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
