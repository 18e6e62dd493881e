#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""unit.schema.UsageLogsTheReadersWriteValidate: the logs unit.capi.UsageRecording* wrote (through the C++ reader and
the C API), and the log `kiln merge-usage` makes of them, validate against variants/schema/usage.schema.json, and
the schema refuses a log with a mistake in it. The merged log holds every selection of the logs it merged.

usage: usage_schema_test.py SOURCE_DIR KILN LOG..."""
import copy
import json
import os
import subprocess
import sys

import jsonschema

source, kiln, logs = sys.argv[1], sys.argv[2], sys.argv[3:]
merged_path = logs[0] + ".merged.json"
subprocess.run([kiln, "merge-usage", *logs, "-o", merged_path], check=True, stdout=subprocess.DEVNULL)


def selections(log):
    return sum(r["count"] for p in log["passes"] for kind in ("served", "missing") for r in p[kind])

schema = json.load(open(os.path.join(source, "variants", "schema", "usage.schema.json")))
jsonschema.Draft202012Validator.check_schema(schema)
validator = jsonschema.Draft202012Validator(schema)
failures = []
merged_selections = selections(json.load(open(merged_path)))
if merged_selections != sum(selections(json.load(open(path))) for path in logs):
    failures.append(f"{merged_path}: {merged_selections} selections, not the sum of the logs'")
for path in logs + [merged_path]:
    log = json.load(open(path))
    failures += [f"{path}: {error.message}" for error in validator.iter_errors(log)]
    if not any(p["served"] for p in log["passes"]):
        failures.append(f"{path}: no served request: the test proves nothing")
    for mistake, change in (("an unknown field", lambda l: l.update(extra=1)),
                            ("another format version", lambda l: l.update(format_version=2)),
                            ("a count of 0", lambda l: l["passes"][0]["served"][0].update(count=0)),
                            ("a tag that is not a string", lambda l: l["tags"].update(scene=3))):
        broken = copy.deepcopy(log)
        change(broken)
        if validator.is_valid(broken):
            failures.append(f"{path}: the schema accepts {mistake}")
print("\n".join(failures) if failures else f"{len(logs)} usage logs and their merge validate; the schema refuses each mistake")
sys.exit(1 if failures else 0)
