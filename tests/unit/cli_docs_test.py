#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The man page (docs/man/kiln.1) and the bash completion (compiler/cli/completion/kiln.bash.in, configured into the
build tree) against the CLI: every option each verb's --help lists is described in the man page and completed for
that verb, every verb is completed, the completion function answers as bash calls it, and its lists of targets and
--emit stages are the ones --help states (both come from kiln/targets.def).

usage: cli_docs_test.py KILN COMPLETION [KILN_VERIFY] SOURCE_DIR"""
import os
import re
import subprocess
import sys

args = sys.argv[1:]
kiln, completion_file, source = args[0], args[1], args[-1]
kiln_verify = args[2] if len(args) == 4 else None
man = open(os.path.join(source, "docs/man/kiln.1")).read()
failures = []


def options_of(program, verb):
    text = subprocess.run([program, verb, "--help"], capture_output=True, text=True, check=True).stdout
    found = []
    for match in re.finditer(r"^\s+((?:-[A-Za-z],)?--[a-z0-9-]+)", text, re.M):
        found.extend(match.group(1).split(","))
    return found


def complete(words):
    """What the completion offers for `words`, the last one being the word under the cursor."""
    script = (f"source {completion_file}\n"
              f"COMP_WORDS=({' '.join(repr(w) for w in words)}); COMP_CWORD={len(words) - 1}\n"
              "_kiln; printf '%s\\n' \"${COMPREPLY[@]}\"\n")
    result = subprocess.run(["bash", "-c", script], capture_output=True, text=True, cwd=source)
    if result.returncode != 0:
        failures.append(f"completion failed for {words}: {result.stderr}")
    return set(result.stdout.split())


top = subprocess.run([kiln, "--help"], capture_output=True, text=True, check=True).stdout
verbs = re.findall(r"^  ([a-z-]+)\s{2,}", top.split("Subcommands:")[1], re.M)
if len(verbs) < 8:
    failures.append(f"found only these verbs in kiln --help: {verbs}")
if complete(["kiln", ""]) != set(verbs):
    failures.append(f"completing a verb offers {sorted(complete(['kiln', '']))}, kiln has {verbs}")
for verb in verbs:
    if not re.search(r'^\.BI? "' + re.escape(verb) + r'[ "]', man, re.M):
        failures.append(f"the man page has no entry for verb '{verb}'")
    program = kiln_verify if verb in ("render", "test") else kiln
    if program is None:
        continue
    offered = complete(["kiln", verb, "-"])
    for option in options_of(program, verb):
        if option == "-h":
            continue
        if option.replace("-", r"\-") not in man:
            failures.append(f"the man page does not describe {verb} {option}")
        if option not in offered:
            failures.append(f"the completion does not offer {option} after 'kiln {verb}'")
for option in ("--color", "--version"):
    if option.replace("-", r"\-") not in man:
        failures.append(f"the man page does not describe {option}")

# Values, and a prefix.
if complete(["kiln", "build", "x.json", "--emit", "sp"]) != {"spvasm"}:
    failures.append("--emit values are not completed")
# The lists generated from kiln/targets.def: as --help states them.
build_help = subprocess.run([kiln, "build", "--help"], capture_output=True, text=True, check=True).stdout
stated_targets = re.search(r"Override the pack's targets: ([a-z0-9, ]+?) \(comma", build_help)
stated_emit = re.search(r"Dump a stage: ([a-z0-9, ]+?) \(repeatable", build_help)
if not stated_targets or not stated_emit:
    failures.append("kiln build --help does not list the targets and --emit stages")
else:
    targets = set(re.split(r", | or ", stated_targets.group(1)))
    if complete(["kiln", "build", "--targets", ""]) != targets or len(targets) < 4:
        failures.append(f"--targets completes {sorted(complete(['kiln', 'build', '--targets', '']))}, --help says {sorted(targets)}")
    emit = set(stated_emit.group(1).split(", "))
    if complete(["kiln", "build", "--emit", ""]) != emit or "spvasm" not in emit:
        failures.append(f"--emit completes {sorted(complete(['kiln', 'build', '--emit', '']))}, --help says {sorted(emit)}")
if complete(["kiln", "--color", "n"]) != {"never"}:
    failures.append("--color values are not completed")
if complete(["kiln", "build", "--remote-u"]) != {"--remote-upload"}:
    failures.append("a build option prefix is not completed")
if "--remote-upload" in complete(["kiln", "lint", "--remote"]):
    failures.append("lint is offered build's options")

for failure in failures:
    print("FAIL:", failure)
sys.exit(1 if failures else 0)
