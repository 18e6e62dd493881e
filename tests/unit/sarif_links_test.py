#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""SARIF help links that open: every rule's helpUri names a file that exists and a section it has, for the kiln
of the build tree (the source tree's docs/lint.md) and for an installed kiln (the lint.md installed beside it,
<prefix>/share/doc/kiln, found from the executable: the install is moved after `cmake --install` to show that a
relocated tree still links).

usage: sarif_links_test.py <cmake> <build dir> <kiln executable of the build tree>"""
import json
import re
import shutil
import subprocess
import sys
import tempfile
import urllib.parse
from pathlib import Path

failures = []


def check(kiln, work, expected_prefix):
    shader = work / "S.hlsl"
    shader.write_text("#ifdef _TYPO_KEYWORD\n#endif\nfloat4 F() : SV_Target { return 1.0; }\n")
    run = subprocess.run([str(kiln), "lint", str(shader), "--format", "sarif"], capture_output=True, text=True, cwd=work)
    log = json.loads(run.stdout)
    rules = log["runs"][0]["tool"]["driver"]["rules"]
    if not rules:
        failures.append(f"{kiln}: no rules in the SARIF log")
    for rule in rules:
        uri = rule["helpUri"]
        if not uri.startswith("file://"):
            failures.append(f"{kiln}: helpUri {uri} is not a file: URI")
            continue
        path, _, anchor = uri[len("file://"):].partition("#")
        path = Path(urllib.parse.unquote(path))
        if not str(path).startswith(str(expected_prefix)):
            failures.append(f"{kiln}: helpUri {uri} is not under {expected_prefix}")
        if not path.is_file():
            failures.append(f"{kiln}: helpUri {uri} names no file")
            continue
        headings = {re.sub(r"[^a-z0-9 -]", "", line.lstrip("#").strip().lower()).replace(" ", "-")
                    for line in path.read_text(encoding="utf-8").splitlines() if line.startswith("#")}
        if anchor not in headings:
            failures.append(f"{kiln}: {path} has no section #{anchor}")
    print(f"{kiln}: {len(rules)} rules, links under {expected_prefix}")


def main():
    cmake, build, build_kiln = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3])
    source_docs = Path(__file__).resolve().parents[2] / "docs"
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        check(build_kiln, work, source_docs)
        installed = work / "prefix"
        subprocess.run([cmake, "--install", str(build), "--prefix", str(installed)], check=True, capture_output=True)
        moved = work / "moved"
        shutil.move(str(installed), str(moved))
        check(moved / "bin" / "kiln", work, moved / "share" / "doc" / "kiln")
    for failure in failures:
        print("FAIL: " + failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
