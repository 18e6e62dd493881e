#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Checks docs/ci/kiln-lint.yml, the GitHub Actions example of docs/lint.md: it parses as YAML (python3-yaml),
has the shape of a workflow, uploads the SARIF file its lint step writes, every repository path it names exists,
the build directory it runs kiln from is the one the `ci` preset configures, and every option it gives kiln is
one `kiln <verb> --help` lists.

usage: ci_workflow_test.py <kiln executable> <kiln source dir>"""
import json
import os
import re
import subprocess
import sys

import yaml

kiln, source = sys.argv[1], sys.argv[2]
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)


with open(os.path.join(source, "docs/ci/kiln-lint.yml"), encoding="utf-8") as f:
    workflow = yaml.safe_load(f)
check(isinstance(workflow, dict) and "jobs" in workflow, "no jobs")
check(True in workflow or "on" in workflow, "no trigger ('on')")  # YAML 1.1 reads a bare `on` as true
steps = [step for job in workflow["jobs"].values() for step in job["steps"]]
commands = "\n".join(step.get("run", "") for step in steps)

upload = [s for s in steps if s.get("uses", "").startswith("github/codeql-action/upload-sarif@")]
check(len(upload) == 1, "no github/codeql-action/upload-sarif step")
sarif_file = upload[0]["with"]["sarif_file"] if upload else None
check(re.search(r"kiln lint .*--format sarif -o %s\b" % re.escape(sarif_file or "?"), commands) is not None,
      "no `kiln lint ... --format sarif -o %s` step before the upload" % sarif_file)
check(any(j.get("permissions", {}).get("security-events") == "write" for j in workflow["jobs"].values()),
      "uploading SARIF needs permissions: security-events: write")

# Repository paths the workflow names exist.
for path in sorted(set(re.findall(r"(?<![\w./])((?:variants|\.ci|docs|shaderlib|tests)/[\w./-]+)", commands))):
    check(os.path.exists(os.path.join(source, path)), "names %s, which does not exist" % path)

# It runs kiln from the ci preset's build directory.
with open(os.path.join(source, "CMakePresets.json"), encoding="utf-8") as f:
    presets = {p["name"]: p for p in json.load(f)["configurePresets"]}
check("ci" in presets, "no ci preset")
binary_dir = presets["ci"]["binaryDir"].replace("${sourceDir}/", "")
for exe in set(re.findall(r"(\S+/kiln)\s", commands)):
    check(exe == binary_dir + "/compiler/kiln", "%s is not the ci preset's kiln (%s/compiler/kiln)" % (exe, binary_dir))

# Every option given to kiln is one its verb knows.
for verb, args in re.findall(r"/kiln (\w[\w-]*)((?:[^|&\n]|\n\s)*)", commands):
    help_text = subprocess.run([kiln, verb, "--help"], capture_output=True, text=True).stdout
    for option in re.findall(r"(?<!\S)(--?[A-Za-z][\w-]*)", args):
        check(re.search(r"(?<![\w-])%s(?![\w-])" % re.escape(option), help_text) is not None,
              "kiln %s has no option %s" % (verb, option))

for f in failures:
    print("FAIL: " + f)
sys.exit(1 if failures else 0)
