#!/usr/bin/env python3
"""unit.schema.UsageLogsTheReadersWriteValidate: the logs unit.capi.UsageRecording* wrote (through the C++ reader and
the C API) validate against variants/schema/usage.schema.json, and the schema refuses a log with a mistake in it.

usage: usage_schema_test.py SOURCE_DIR LOG..."""
import copy
import json
import os
import sys

import jsonschema

source, logs = sys.argv[1], sys.argv[2:]
schema = json.load(open(os.path.join(source, "variants", "schema", "usage.schema.json")))
jsonschema.Draft202012Validator.check_schema(schema)
validator = jsonschema.Draft202012Validator(schema)
failures = []
for path in logs:
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
print("\n".join(failures) if failures else f"{len(logs)} usage logs validate; the schema refuses each mistake")
sys.exit(1 if failures else 0)
