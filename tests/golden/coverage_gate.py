#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""golden.coverage: which lines of shaderlib/ the golden scenes execute (issue 40; docs/coverage.md).

Builds the golden packs again with `kiln build --coverage` (the default pack, and the night_city and audit scene
profiles' packs), renders each golden scene's variants with `kiln test --coverage` on Vulkan against the same
references and limits as the golden tests, draws the audit scene with the DepthOnly and DepthNormals passes
(`kiln render --pass`; golden.EveryApi/DepthPasses judges their images), and merges the tracefiles. Then:
  - genhtml renders the merged tracefile and `lcov --summary` reads the totals kiln printed (lcov's own parser);
  - every line no pixel lit ("dark") must be listed, with its reason, in docs/golden.md's table of dark lines,
    and every line listed there must still be dark: the table cannot drift from the measurement;
  - the instrumented modules compute what the plain ones do: a variant of the audit profile's pack, built with -g
    alone and with --coverage, renders bit-identical float images on Vulkan, GL and GLES;
  - GL and GLES measure what Vulkan measures: the strength-2 sample of spheres run with --api gl and --api gles
    lights exactly the lines the Vulkan run of that sample lights (the GLSL is the instrumented SPIR-V's translation);
  - the per-scene JSON (each line's hits) is left for the mutation gate, which reports a mutant whose lines are
    dark as "not covered" instead of judging it.

  coverage_gate.py --kiln KILN --source SOURCE_DIR --work GOLDEN_WORK --out DIR [--cover N] [--scenes a,b]

--cover N renders a strength-N covering sample of the spheres and night_city variants instead of all of them (the
audit scene's 14 judged variants are always all rendered); the table of dark lines holds for both (docs/golden.md).
Exit 0 when the table matches and the tools agree; 1 otherwise."""
import argparse
import json
import os
import re
import subprocess
import sys
import time

SCENES = {"spheres": "lit", "night_city": "night_city", "audit": "audit"}  # scene -> pack of golden.setup
DARK_ROW = re.compile(r"^\| `([A-Za-z0-9_/]+\.hlsl):(\d+)` \| (.+?) \|$", re.M)


def library_name(path):
    """The name of a library file from the path a module recorded: from shaderlib/ on."""
    at = path.replace("\\", "/").rfind("shaderlib/")
    return path[at + len("shaderlib/"):] if at >= 0 else None


def read_lcov(path, functions=None):
    """{file: {line: hits}} of one tracefile; its function records added to `functions`, {file: {name: [line, hits]}}."""
    lines, current, named = {}, None, None
    for row in open(path, encoding="utf-8"):
        row = row.strip()
        if row.startswith("SF:"):
            current = lines.setdefault(row[3:], {})
            named = None if functions is None else functions.setdefault(library_name(row[3:]), {})
        elif row.startswith("DA:") and current is not None:
            number, hits = row[3:].split(",")[:2]
            current[int(number)] = current.get(int(number), 0) + int(hits)
        elif row.startswith("FN:") and named is not None:
            number, name = row[3:].split(",", 1)
            named.setdefault(name, [int(number), 0])
        elif row.startswith("FNDA:") and named is not None:
            hits, name = row[5:].split(",", 1)
            named.setdefault(name, [0, 0])[1] += int(hits)
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kiln", required=True)
    parser.add_argument("--source", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--cover", default="0")
    parser.add_argument("--scenes", default=",".join(SCENES))
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    failures = []
    start = time.monotonic()

    # The packs, instrumented: the same definitions and profiles as golden.setup's.
    packs = {}
    for scene in args.scenes.split(","):
        pack = os.path.join(args.out, "packs", scene)
        command = [args.kiln, "build", os.path.join(args.source, "variants/lit.pack.json"), "--coverage", "-o", pack,
                   "--cache", os.path.join(args.work, "cache"), "-q"]
        if scene != "spheres":
            command += ["--scene", os.path.join(args.source, "variants/scenes", scene + ".json")]
        subprocess.run(command, check=True)
        packs[scene] = pack
    built = time.monotonic()

    # Instrumented and plain (-g, the same code without the probes): the same bits.
    if "audit" in packs:
        plain = os.path.join(args.out, "packs", "audit-g")
        subprocess.run([args.kiln, "build", os.path.join(args.source, "variants/lit.pack.json"), "-g", "-o", plain,
                        "--scene", os.path.join(args.source, "variants/scenes/audit.json"),
                        "--cache", os.path.join(args.work, "cache"), "-q"], check=True)
        manifest = json.load(open(os.path.join(plain, "lit.manifest.json"), encoding="utf-8"))
        variants = next(p for p in manifest["passes"] if p["name"] == "Forward")["variants"]
        for variant in (variants[len(variants) // 2],):
            keywords = " ".join(variant["keywords"])
            for api in ("vulkan", "gl", "gles"):
                images = []
                for pack in (plain, packs["audit"]):
                    image = os.path.join(args.out, f"identical-{len(images)}.kimg")
                    subprocess.run([args.kiln, "render", pack, "--variant", keywords, "--api", api, "--size", "96x96",
                                    "--scene", os.path.join(args.source, "variants/scenes/render/audit.json"),
                                    "-o", image[:-5] + ".png", "--exr", image], check=True, capture_output=True)
                    images.append(open(image, "rb").read())
                if images[0] != images[1]:
                    failures.append(f"variant '{keywords}' on {api}: the --coverage pack's image differs from the -g pack's")
        print(f"identical: a variant on 3 APIs, --coverage against -g")
    checked = time.monotonic()

    merged, per_scene, functions = {}, {}, {}  # functions: {file: {name: [line, hits]}}, from kiln test's FN records
    for scene, pack in packs.items():
        tracefile = os.path.join(args.out, scene + ".info")
        command = [args.kiln, "test", pack, "--scene", os.path.join(args.source, "variants/scenes/render", scene + ".json"),
                   "--golden", os.path.join(args.work, "goldens", scene),
                   "--tolerances", os.path.join(args.source, "variants/scenes/render/tolerances.json"),
                   "--coverage", tracefile, "--coverage-json", os.path.join(args.out, scene + ".json")]
        if args.cover != "0" and scene != "audit":
            command += ["--cover", args.cover]
        test = subprocess.run(command, capture_output=True, text=True)
        summary = [line for line in test.stdout.splitlines() if line.startswith("kiln test:")]
        print(f"{scene}: " + "; ".join(line[len("kiln test: "):] for line in summary[-3:]))
        if test.returncode != 0:
            failures.append(f"kiln test --coverage failed on {scene} (exit {test.returncode}): the instrumented pack must "
                            f"render within the golden limits\n{test.stdout[-3000:]}{test.stderr}")
            continue
        lines = {}
        for path, hits in read_lcov(tracefile, functions).items():
            name = library_name(path)
            if name is None:
                failures.append(f"{scene}: a line of '{path}', which is not in shaderlib/")
                continue
            for number, count in hits.items():
                lines.setdefault(name, {})[number] = lines.get(name, {}).get(number, 0) + count
                merged.setdefault(name, {})[number] = merged.get(name, {}).get(number, 0) + count
        per_scene[scene] = lines
    # The depth passes, which kiln test does not draw: their lines count for the audit scene.
    if "audit" in packs:
        for depth_pass in ("DepthOnly", "DepthNormals"):
            tracefile = os.path.join(args.out, f"audit-{depth_pass}.info")
            subprocess.run([args.kiln, "render", packs["audit"], "--pass", depth_pass, "-o", tracefile[:-5] + ".png",
                            "--scene", os.path.join(args.source, "variants/scenes/render/audit.json"), "--coverage", tracefile],
                           check=True, capture_output=True)
            for path, hits in read_lcov(tracefile, functions).items():
                for number, count in hits.items():
                    for lines in (per_scene.setdefault("audit", {}), merged):
                        lines.setdefault(library_name(path), {})[number] = lines.get(library_name(path), {}).get(number, 0) + count

    # The same measurement through the GLSL outputs, on the strength-2 sample of spheres.
    if "spheres" in packs:
        lit_lines = {}
        for api in ("vulkan", "gl", "gles"):
            tracefile = os.path.join(args.out, "spheres.info") if api == "vulkan" and args.cover == "2" else \
                os.path.join(args.out, f"spheres-sample-{api}.info")
            if api != "vulkan" or args.cover != "2":
                test = subprocess.run([args.kiln, "test", packs["spheres"], "--api", api, "--cover", "2",
                                       "--scene", os.path.join(args.source, "variants/scenes/render/spheres.json"),
                                       "--golden", os.path.join(args.work, "goldens", "spheres"),
                                       "--tolerances", os.path.join(args.source, "variants/scenes/render/tolerances.json"),
                                       "--coverage", tracefile], capture_output=True, text=True)
                if test.returncode != 0:
                    failures.append(f"kiln test --coverage --api {api} failed on spheres (exit {test.returncode})\n"
                                    f"{test.stdout[-3000:]}{test.stderr}")
                    continue
            lit_lines[api] = {(library_name(p), n) for p, lines in read_lcov(tracefile).items() for n, h in lines.items() if h}
        for api in ("gl", "gles"):
            if api in lit_lines and "vulkan" in lit_lines and lit_lines[api] != lit_lines["vulkan"]:
                failures.append(f"spheres on {api} lights other lines than on Vulkan: only {api}: "
                                f"{sorted(lit_lines[api] - lit_lines['vulkan'])[:8]}, only Vulkan: "
                                f"{sorted(lit_lines['vulkan'] - lit_lines[api])[:8]}")
        print(f"GL and GLES: the spheres sample lights the {len(lit_lines.get('vulkan', ()))} lines Vulkan's lights")
    rendered = time.monotonic()

    # The merged tracefile, with the sources' paths (genhtml reads them).
    merged_path = os.path.join(args.out, "coverage.info")
    with open(merged_path, "w", encoding="utf-8") as out:
        out.write("TN:golden\n")
        for name in sorted(merged):
            out.write(f"SF:{os.path.join(args.source, 'shaderlib', name)}\n")
            named = functions.get(name, {})
            for function, (number, _) in sorted(named.items(), key=lambda f: (f[1][0], f[0])):
                out.write(f"FN:{number},{function}\n")
            for function, (_, hits) in sorted(named.items(), key=lambda f: (f[1][0], f[0])):
                out.write(f"FNDA:{hits},{function}\n")
            if named:
                out.write(f"FNF:{len(named)}\nFNH:{sum(1 for _, h in named.values() if h)}\n")
            for number in sorted(merged[name]):
                out.write(f"DA:{number},{merged[name][number]}\n")
            hit = sum(1 for h in merged[name].values() if h)
            out.write(f"LF:{len(merged[name])}\nLH:{hit}\nend_of_record\n")
    with open(os.path.join(args.out, "coverage.json"), "w", encoding="utf-8") as out:
        json.dump({"scenes": per_scene, "merged": merged}, out, indent=1, sort_keys=True)

    total = sum(len(lines) for lines in merged.values())
    hit = sum(1 for lines in merged.values() for h in lines.values() if h)
    print(f"{'file':<28} {'lines':>6} {'lit':>6} {'cover':>7}")
    for name in sorted(merged):
        n, h = len(merged[name]), sum(1 for x in merged[name].values() if x)
        print(f"{name:<28} {n:>6} {h:>6} {100.0 * h / n:>6.1f}%")
    print(f"{'all':<28} {total:>6} {hit:>6} {100.0 * hit / max(total, 1):>6.1f}%")

    # lcov's own reading of the tracefile, and genhtml's rendering of it.
    summary = subprocess.run(["lcov", "--summary", merged_path], capture_output=True, text=True)
    m = re.search(r"lines\.+: [\d.]+% \((\d+) of (\d+) lines\)", summary.stdout + summary.stderr)
    if not m or (int(m.group(1)), int(m.group(2))) != (hit, total):
        failures.append(f"lcov --summary does not read {hit} of {total} lines:\n{summary.stdout}{summary.stderr}")
    # Function records (verify/coverage/hlsl_functions.hpp): every file with lines has them, lcov reads the
    # totals the records give, and the BRDF's D_GGX is entered.
    function_count = sum(len(named) for named in functions.values())
    entered = sum(1 for named in functions.values() for _, h in named.values() if h)
    m = re.search(r"functions\.+: [\d.]+% \((\d+) of (\d+) functions\)", summary.stdout + summary.stderr)
    if not m or (int(m.group(1)), int(m.group(2))) != (entered, function_count):
        failures.append(f"lcov --summary does not read {entered} of {function_count} functions:\n{summary.stdout}{summary.stderr}")
    if sorted(f for f in functions if f) != sorted(merged):
        failures.append(f"files without function records: {sorted(set(merged) - set(functions))}")
    if functions.get("BRDF.hlsl", {}).get("D_GGX", [0, 0])[1] == 0:
        failures.append("BRDF.hlsl's D_GGX, which every lit draw runs, has no function record with hits")
    print(f"functions: {entered} of {function_count} entered")
    html = subprocess.run(["genhtml", "--quiet", "-o", os.path.join(args.out, "html"), merged_path],
                          capture_output=True, text=True)
    if html.returncode != 0 or not os.path.isfile(os.path.join(args.out, "html", "index.html")):
        failures.append(f"genhtml cannot render the tracefile:\n{html.stdout}{html.stderr}")

    # The dark lines against docs/golden.md's table.
    doc = open(os.path.join(args.source, "docs/golden.md"), encoding="utf-8").read()
    listed = {(f, int(n)): reason for f, n, reason in DARK_ROW.findall(doc)}
    if len(packs) == len(SCENES):
        dark = {(name, n) for name, lines in merged.items() for n, h in lines.items() if not h}
        source_line = lambda f, n: open(os.path.join(args.source, "shaderlib", f), encoding="utf-8").read().splitlines()[n - 1].strip()
        for f, n in sorted(dark - set(listed)):
            failures.append(f"dark line {f}:{n} (`{source_line(f, n)}`) is not in docs/golden.md's table of dark lines: "
                            "light it with a scene, or list it with its reason")
        for f, n in sorted(set(listed) - dark):
            failures.append(f"docs/golden.md lists {f}:{n} as dark, but the golden scenes light it (or it has no code): "
                            "remove its row")
        print(f"dark lines: {len(dark)}")
    print(f"coverage gate: {hit} of {total} lines lit; build {built - start:.0f} s, identical images {checked - built:.0f} s, "
          f"render {rendered - checked:.0f} s, "
          f"tracefile {merged_path}")
    for failure in failures:
        print("FAIL: " + failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
