#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""unit.schema: the JSON schemas in variants/schema/ and kiln agree.

Every bundled pack definition and scene profile validates against its schema, and on a set of small cases
(valid ones and one mistake each) the schema and `kiln list` give the same verdict: an editor that checks a
file with the schema tells the user what kiln would.

    schema_agreement_test.py KILN SOURCE_DIR
"""
import json
import os
import subprocess
import sys
import tempfile

import jsonschema

kiln, source = os.path.abspath(sys.argv[1]), sys.argv[2]
schemas = {name: json.load(open(os.path.join(source, "variants", "schema", f"{name}.schema.json")))
           for name in ("pack", "scene")}
for schema in schemas.values():
    jsonschema.Draft202012Validator.check_schema(schema)
failures = []


def schema_errors(kind, document):
    validator = jsonschema.Draft202012Validator(schemas[kind])
    return [e.message for e in validator.iter_errors(document)]


# The bundled files.
bundled = 0
for kind, folder, suffix in (("pack", "variants", ".pack.json"), ("scene", "variants/scenes", ".json")):
    for name in sorted(os.listdir(os.path.join(source, folder))):
        path = os.path.join(source, folder, name)
        if not name.endswith(suffix) or not os.path.isfile(path):
            continue
        bundled += 1
        for message in schema_errors(kind, json.load(open(path))):
            failures.append(f"{folder}/{name}: {message}")
if bundled < 5:
    failures.append(f"only {bundled} bundled files found")

PASS = {"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}
PACK = {"name": "p", "passes": [PASS]}


def pack(**changes):
    document = json.loads(json.dumps(PACK))
    document.update(changes)
    return document


def with_pass(**changes):
    return pack(passes=[dict(PASS, **changes)])


CONSTRAINT = {"keyword": "A", "requires": ["B"]}
pack_cases = [
    ("minimal", pack()),
    ("every field", pack(**{"$schema": "../schema/pack.schema.json", "description": "d", "include_dirs": ["."],
                           "targets": ["glsl", "msl"], "budget": 8, "constraints": [dict(CONSTRAINT, reason="r")],
                           "materials": [{"name": "m", "description": "d", "keywords": ["C"]}],
                           "scene_features": {"fog": {"true": ["A"], "false": []}}})),
    ("pass description", with_pass(description="d")),
    ("unknown field", pack(budjet=8)),
    ("unknown pass field", with_pass(colour=1)),
    ("unknown constraint field", pack(constraints=[dict(CONSTRAINT, because="r")])),
    ("unknown material field", pack(materials=[{"name": "m", "keyword": ["C"]}])),
    ("unknown stage", with_pass(stages={"vertex": "V", "pixel": "F"})),
    ("no stages", with_pass(stages={})),
    ("no passes", pack(passes=[])),
    ("no name", {"passes": [PASS]}),
    ("bad name", pack(name="my pack")),
    ("empty name", pack(name="")),
    ("name that is a path", pack(name="..")),
    ("pass name that is a path", with_pass(name="../../x")),
    ("pass name too long", with_pass(name="P" * 129)),
    ("shift over the limit", pack(bindings={"shifts": [{"register": "t", "shift": 4294967295}]})),
    ("zero budget", pack(budget=0)),
    ("string budget", pack(budget="8")),
    ("unknown target", pack(targets=["vulkan"])),
    ("constraint without a rule", pack(constraints=[{"keyword": "A"}])),
    ("material without a name", pack(materials=[{"keywords": ["C"]}])),
    ("bindings, every field", pack(bindings={"shifts": [{"register": "t", "shift": 16}, {"register": "s", "shift": 32,
                                                                                        "space": 1},
                                                        {"register": "u", "shift": 8, "space": "all"}],
                                             "auto_bind": False, "combined_image_samplers": True,
                                             "global_uniform": {"binding": 3, "set": 1}})),
    ("pass bindings and defines", with_pass(bindings={"combined_image_samplers": True}, defines={"N": 2, "Q": "HIGH"})),
    ("pack defines", pack(defines={"FAST": True, "LEVEL": 3, "NAME": "x"})),
    ("unknown bindings field", pack(bindings={"shift": []})),
    ("unknown shift field", pack(bindings={"shifts": [{"register": "t", "shift": 1, "set": 0}]})),
    ("unknown register class", pack(bindings={"shifts": [{"register": "c", "shift": 1}]})),
    ("negative shift", pack(bindings={"shifts": [{"register": "t", "shift": -1}]})),
    ("shift without a register", pack(bindings={"shifts": [{"shift": 1}]})),
    ("string auto_bind", pack(bindings={"auto_bind": "yes"})),
    ("global_uniform without binding", pack(bindings={"global_uniform": {"set": 1}})),
    ("define not an identifier", pack(defines={"2X": 1})),
    ("define with an array value", with_pass(defines={"X": [1]})),
    ("lint disable", pack(lint={"disable": ["unused-keyword", "fp16-unguarded"]})),
    ("unknown lint rule", pack(lint={"disable": ["unused-keywords"]})),
    ("unknown lint field", pack(lint={"enable": ["unused-keyword"]})),
    ("lint not an object", pack(lint=["unused-keyword"])),
]
scene_cases = [
    ("keywords", {"name": "s", "keywords": ["A"]}),
    ("every field", {"$schema": "../schema/scene.schema.json", "name": "s", "description": "d",
                     "uses": {"fog": True}, "materials": ["m"], "keywords": ["A"]}),
    ("nothing used", {"name": "s"}),
    ("no name", {"keywords": ["A"]}),
    ("unknown field", {"name": "s", "keywords": ["A"], "material": ["m"]}),
    ("keywords not strings", {"name": "s", "keywords": [1]}),
    ("name that is a path", {"name": "../s", "keywords": ["A"]}),
]

SHADER = ("#pragma multi_compile _ A\n#pragma multi_compile _ B\n#pragma shader_feature _ C\n"
          "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
          "float4 F() : SV_Target { return 1.0; }\n")
# The scene cases run against a pack whose scene_features and materials they can name.
SCENE_PACK = pack(materials=[{"name": "m", "keywords": []}], scene_features={"fog": {"true": ["A"], "false": []}})

with tempfile.TemporaryDirectory() as work:
    with open(os.path.join(work, "S.hlsl"), "w") as f:
        f.write(SHADER)

    def kiln_accepts(pack_document, scene_document=None):
        with open(os.path.join(work, "p.pack.json"), "w") as f:
            json.dump(pack_document, f)
        command = [kiln, "list", "p.pack.json"]
        if scene_document is not None:
            with open(os.path.join(work, "scene.json"), "w") as f:
                json.dump(scene_document, f)
            command += ["--scene", "scene.json"]
        run = subprocess.run(command, cwd=work, capture_output=True, text=True)
        if run.returncode not in (0, 1):
            failures.append(f"kiln list exited with {run.returncode}: {run.stderr}")
        return run.returncode == 0, run.stderr

    for kind, cases in (("pack", pack_cases), ("scene", scene_cases)):
        for name, document in cases:
            errors = schema_errors(kind, document)
            accepted, stderr = kiln_accepts(document) if kind == "pack" else kiln_accepts(SCENE_PACK, document)
            verdict = f"schema {'accepts' if not errors else 'refuses'}, kiln {'accepts' if accepted else 'refuses'}"
            print(f"{kind} / {name}: {verdict}")
            if accepted == bool(errors):
                failures.append(f"{kind} case '{name}': {verdict}\n  schema: {errors}\n  kiln: {stderr.strip()}")

if failures:
    print("\n".join(["FAIL"] + failures))
    sys.exit(1)
print(f"{bundled} bundled files valid; {len(pack_cases) + len(scene_cases)} cases: the schemas and kiln agree")
