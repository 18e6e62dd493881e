#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""golden.specialized.variants: the specialized pack (variants/lit_specialized.pack.json) holds exactly the default
pack's variants, pass by pass, with fewer modules; every folded keyword the manifest records is one of the pack's
keyword_kinds, at the place kiln/folded_keywords.hpp derives. Its images are golden.{api}.spheres.specialized's."""
import argparse
import json
import sys


def load(path):
    with open(path) as f:
        return json.load(f)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--default", required=True, help="the default pack's manifest")
    parser.add_argument("--specialized", required=True, help="the specialized pack's manifest")
    parser.add_argument("--definition", required=True, help="variants/lit_specialized.pack.json")
    args = parser.parse_args()
    default, specialized = load(args.default), load(args.specialized)
    kinds = load(args.definition)["keyword_kinds"]
    failures = []
    for a, b in zip(default["passes"], specialized["passes"]):
        if a["name"] != b["name"]:
            failures.append(f"pass {a['name']} is {b['name']} in the specialized pack")
            continue
        va = sorted(tuple(v["keywords"]) for v in a["variants"])
        vb = sorted(tuple(v["keywords"]) for v in b["variants"])
        if va != vb:
            failures.append(f"{a['name']}: {len(set(va) - set(vb))} variants missing, {len(set(vb) - set(va))} extra")
        modules = lambda m: len({json.dumps(v["binaries"], sort_keys=True) for v in m["variants"]})
        print(f"{a['name']}: {len(va)} variants; distinct stage pairs {modules(a)} -> {modules(b)}")
        next_id, next_offset, group_id, place = 1000, 0, None, 0
        for entry in b.get("folded_keywords", []):
            if entry["keyword"] != "_" and kinds.get(entry["keyword"]) != entry["kind"]:
                failures.append(f"{a['name']}: {entry['keyword']} is folded as {entry['kind']}, the pack asks "
                                f"{kinds.get(entry['keyword'])}")
            if entry["kind"] == "specialization_constant_int":
                # One id per group; its values in order, the off value "_" counted.
                if entry["value"] == 0:
                    group_id, place = next_id, 0
                    next_id += 1
                if entry["constant_id"] != group_id or entry["value"] != place or entry["type"] != "int":
                    failures.append(f"{entry['keyword']}: constant {entry['constant_id']} value {entry['value']}, "
                                    f"expected {group_id} value {place}")
                place += 1
            elif entry["kind"] == "specialization_constant":
                if entry["constant_id"] != next_id:
                    failures.append(f"{entry['keyword']}: constant id {entry['constant_id']}, expected {next_id}")
                next_id += 1
            else:
                if entry["offset"] != next_offset:
                    failures.append(f"{entry['keyword']}: offset {entry['offset']}, expected {next_offset}")
                next_offset += 4
    if len(default["passes"]) != len(specialized["passes"]):
        failures.append("the packs have different passes")
    if len(specialized["binaries"]) >= len(default["binaries"]):
        failures.append(f"the specialized pack has {len(specialized['binaries'])} modules, the default "
                        f"{len(default['binaries'])}: nothing was folded")
    print(f"modules: {len(default['binaries'])} -> {len(specialized['binaries'])}")
    for failure in failures:
        print("FAIL", failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
