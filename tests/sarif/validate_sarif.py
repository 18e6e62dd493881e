#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Validates SARIF files against the official SARIF 2.1.0 JSON schema (sarif-schema-2.1.0.json beside this
script, see NOTICE.md) with python3-jsonschema, and checks what the schema cannot: every artifact URI is a
valid URI reference (percent-encoded), every result has a region, and a relative URI names its uriBaseId.

usage: validate_sarif.py FILE...   (exit 0 when every file is valid; each problem is printed)"""
import json
import os
import re
import sys

import jsonschema

SCHEMA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "sarif-schema-2.1.0.json")
# RFC 3986 characters allowed in a URI reference (unreserved, reserved, and '%' of a %XX escape).
URI_CHARS = re.compile(r"^[A-Za-z0-9\-._~:/?#\[\]@!$&'()*+,;=%]*$")
PERCENT = re.compile(r"%(?![0-9A-Fa-f]{2})")


def problems(path, schema):
    with open(path, encoding="utf-8") as f:
        log = json.load(f)
    validator = jsonschema.Draft4Validator(schema)
    for error in sorted(validator.iter_errors(log), key=lambda e: list(e.path)):
        yield "schema: %s at /%s" % (error.message, "/".join(str(p) for p in error.path))
    for r, run in enumerate(log.get("runs") or []):
        bases = run.get("originalUriBaseIds", {})
        for i, result in enumerate(run.get("results", [])):
            where = "runs/%d/results/%d" % (r, i)
            locations = result.get("locations", [])
            if not locations:
                yield "%s: no location" % where
            for location in locations:
                physical = location.get("physicalLocation", {})
                if "region" not in physical:
                    yield "%s: no region" % where
                uri = physical.get("artifactLocation", {}).get("uri", "")
                if not URI_CHARS.match(uri) or PERCENT.search(uri):
                    yield "%s: uri %r is not a percent-encoded URI reference" % (where, uri)
                base = physical.get("artifactLocation", {}).get("uriBaseId")
                if not re.match(r"^[a-z][a-z0-9+.-]*:", uri) and base not in bases:
                    yield "%s: relative uri %r without a uriBaseId from originalUriBaseIds" % (where, uri)


def main():
    with open(SCHEMA, encoding="utf-8") as f:
        schema = json.load(f)
    failed = False
    for path in sys.argv[1:]:
        for problem in problems(path, schema):
            print("%s: %s" % (path, problem))
            failed = True
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
