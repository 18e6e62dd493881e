#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Docs that cannot drift (issue: one row per named thing, docs that cannot drift).

  defaults  every default the README, docs/*.md and the man page state for a `kiln build` option equals the one
            `kiln build --help` prints, and --help's come from kiln/defaults.hpp (the code's).
  map       every file and folder docs/design.md names exists (resolved against the folders its text is about),
            and the counts it states hold: build_pack's length, the fuzz corpus's file count.

usage: docs_truth_test.py defaults|map <kiln executable> <source dir>"""
import re
import subprocess
import sys
from pathlib import Path

failures = []


def fail(message):
    failures.append(message)
    print("FAIL: " + message)


def check_defaults(kiln, root):
    help_text = subprocess.run([kiln, "build", "--help"], capture_output=True, text=True, check=True).stdout
    stated = {}  # option -> the default --help states
    for match in re.finditer(r"(--[a-z][a-z0-9-]+)[^\n]*(?:\n {10,}[^\n]*)*?\(default: ([0-9.]+)\)", help_text):
        stated[match.group(1)] = float(match.group(2))
    for option in ("--worker-timeout", "--cache-max-mb", "--remote-connect-timeout", "--remote-timeout", "--remote-transfers"):
        if option not in stated:
            fail(f"kiln build --help states no default for {option}")
    documents = [root / "README.md", root / "docs/man/kiln.1"] + sorted((root / "docs").glob("*.md"))
    checked = 0
    for document in documents:
        text = document.read_text(encoding="utf-8")
        for option, value in stated.items():
            spellings = [re.escape(option), re.escape(option).replace("\\-", "\\\\-")]  # the man page writes \-\-
            for spelling in spellings:
                for match in re.finditer(spelling + r"\b", text):
                    window = text[match.end():match.end() + 80]
                    found = re.match(r"[^.;|)]*?(?:default:?\s+([0-9.]+)|([0-9.]+)\s*(?:s|MB|MiB)?\s+by default)", window)
                    if not found:
                        continue
                    number = float(found.group(1) or found.group(2))
                    checked += 1
                    if number != value:
                        fail(f"{document.relative_to(root)}: {option} default {number:g}, the code's is {value:g}")
    print(f"{len(stated)} defaults in --help, {checked} statements of them in the docs checked")
    # The version is stated once, in CMake's project(); kiln --version and the man page say the same.
    version = re.search(r"project\(kiln VERSION ([0-9.]+)", (root / "CMakeLists.txt").read_text()).group(1)
    first = subprocess.run([kiln, "--version"], capture_output=True, text=True, check=True).stdout.splitlines()[0]
    if first != "kiln " + version:
        fail(f"kiln --version says '{first}', CMakeLists.txt's project version is {version}")
    man_title = re.search(r'^\.TH KILN 1 \S+ "kiln ([0-9.]+)"', (root / "docs/man/kiln.1").read_text(), re.M)
    if not man_title or man_title.group(1) != version:
        fail(f"docs/man/kiln.1's .TH line does not name version {version}")
    if checked < 4:
        fail("fewer default statements found than the docs hold: the pattern no longer matches them")


def check_map(root):
    design = (root / "docs/design.md").read_text(encoding="utf-8")
    bases = [root, root / "compiler/src", root / "compiler/include", root / "compiler", root / "verify", root / "tests",
             root / "compiler/cli"]
    named = 0
    for token in sorted(set(re.findall(r"`([^`\s]+)`", design))):
        if "/" not in token or token.startswith(("../", "/", "http")) or re.search(r"[<>*{}$]|\.\.\.", token):
            continue
        path = token.split("'")[0].rstrip(":,.")
        if not re.fullmatch(r"[A-Za-z0-9_./-]+", path):
            continue
        named += 1
        candidates = [base / path for base in bases]
        # A stem names its .cpp/.hpp pair: `driver/messages`.
        candidates += [Path(str(c) + ext) for c in candidates for ext in (".cpp", ".hpp")]
        if not any(c.exists() for c in candidates):
            fail(f"docs/design.md names `{token}`, which does not exist")
    print(f"docs/design.md names {named} files and folders")
    # The counts it states.
    pipeline = (root / "compiler/src/driver/pipeline.cpp").read_text(encoding="utf-8")
    body = re.search(r"\nBuildReport build_pack\([^)]*\)[^{]*\{\n(.*?)\n\}\n", pipeline, re.S)
    stated = re.search(r"`build_pack` is the pipeline: about (\d+) lines", design)
    if not body or not stated:
        fail("build_pack's length: the function or the sentence stating it is not found")
    else:
        lines = body.group(1).count("\n") + 1
        if abs(lines - int(stated.group(1))) > int(stated.group(1)) // 4:
            fail(f"docs/design.md says build_pack is about {stated.group(1)} lines; it is {lines}")
    corpus = re.search(r"\(`tests/fuzz/corpus/`, (\d+) files", design)
    if corpus:
        files = sum(1 for p in (root / "tests/fuzz/corpus").rglob("*") if p.is_file())
        if files != int(corpus.group(1)):
            fail(f"docs/design.md says the fuzz corpus has {corpus.group(1)} files; it has {files}")


def code_lines(root, folders, suffixes):
    """(path relative to root, line) of every line of code (not a comment) under `folders`."""
    for folder in folders:
        for path in sorted((root / folder).rglob("*")):
            if not path.is_file() or not path.name.endswith(suffixes):
                continue
            for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
                if not line.lstrip().startswith(("//", "#", "/*", "* ", "*/")):
                    yield str(path.relative_to(root)), line


def check_one_row_per_thing(root):
    """What design.md's "What a contributor touches" promises: targets and lint rules are each listed in one table,
    so no other code spells out the list of targets or a lint rule's id; and the numbers it states hold."""
    design = (root / "docs/design.md").read_text(encoding="utf-8")
    suffixes = (".cpp", ".hpp", ".h", ".def", ".cmake", ".txt", ".in")
    target_list = re.compile(r"spirv\W+glsl\W+gles\W+msl", re.I)
    table = "compiler/include/kiln/targets.def"
    for path, line in code_lines(root, ["compiler", "verify", "cmake"], suffixes):
        if path != table and target_list.search(line):
            fail(f"{path} lists the targets ({line.strip()[:80]}): generate it from {table}")
    rules = (root / "compiler/include/kiln/lint_rules.def").read_text(encoding="utf-8")
    ids = re.findall(r'^KILN_LINT_RULE\(\w+, "([a-z0-9-]+)", \w+, \w+\)$', rules, re.M)
    if len(ids) < 10:
        fail(f"compiler/include/kiln/lint_rules.def: found only {len(ids)} rules")
    for path, line in code_lines(root, ["compiler", "verify"], suffixes):
        for rule in ids:
            if f'"{rule}"' in line and not path.endswith("kiln/lint_rules.def"):
                fail(f"{path} spells lint rule id \"{rule}\": name it by its RuleId (compiler/include/kiln/lint_rules.def)")
    stated = re.search(r"`cross/glsl_target.cpp` is (\d+) lines", design)
    lines = len((root / "compiler/src/cross/glsl_target.cpp").read_text(encoding="utf-8").splitlines())
    if not stated or int(stated.group(1)) != lines:
        fail(f"docs/design.md's length of cross/glsl_target.cpp is not its {lines} lines")
    for what, count in re.findall(r"^- \*\*A (target|manifest field|lint rule|keyword pragma)\*\*(?: \([^)]*\))?, (\d+) files?\b", design, re.M):
        print(f"docs/design.md: a {what} touches {count} file(s)")
    if len(re.findall(r"^- \*\*A (?:target|manifest field|lint rule|keyword pragma)\*\*(?: \([^)]*\))?, \d+ files?\b", design, re.M)) != 4:
        fail("docs/design.md does not say how many files a target, a manifest field, a lint rule and a keyword pragma touch")


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    if sys.argv[1] == "defaults":
        check_defaults(sys.argv[2], Path(sys.argv[3]))
    else:
        check_map(Path(sys.argv[2]))
        check_one_row_per_thing(Path(sys.argv[2]))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
