#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""pipeline.corpus.KilnBuildsWhatGlslangAndGlslcBuild: a differential test of kiln against glslangValidator and glslc
on the compatibility corpus (tests/corpus/*.hlsl; the header format is corpus_test.cpp's).

For every corpus file and every stage its `// stages:` header names, the stage is compiled with glslangValidator and
with glslc, with the command-line options equivalent to the file's bindings (its `// option:` object, or kiln's
defaults; the table is docs/bindings.md's), and the file is built with the kiln CLI as a one-pass pack (as
corpus_test.cpp builds it). Then:

  Rule A  every file that either tool builds (all its stages), kiln builds too.
  Rule B  for each stage, the descriptor bindings of each tool's SPIR-V agree with kiln's reflection of that stage:
          the set of (set, binding, kind) and the push-constant block sizes. The tools' SPIR-V is read by the small
          reader below (no kiln code, no SPIRV-Cross).

Which resources are compared: those the entry point statically references, i.e. the global variables that the
functions reachable from the entry point (through OpFunctionCall) load, store, index, take a texel pointer of, apply
an atomic to or pass on. kiln's reflection lists the resources left in its optimized SPIR-V, and its optimizer
removes declarations the entry point does not use; both tools already run glslang's HLSL legalization (on by default),
which removes them too, and the reachability rule makes the comparison independent of that: a tool that kept a dead
declaration would not count it. A resource referenced only by dead code that kiln's optimizer (spirv-opt -O) removes
but the tools' legalization keeps would show as a difference: none in the corpus today; such a case is reported, not
hidden.

Option mapping (kiln "bindings" -> glslangValidator | glslc), always with HLSL register-class mapping on
(kiln: always; --hlsl-iomap | -fhlsl-iomap), 16-bit types on (kiln: always; --hlsl-enable-16bit-types |
-fhlsl-16bit-types) and kiln's target environment (Vulkan 1.1 / SPIR-V 1.3; --target-env vulkan1.1 |
--target-env=vulkan1.1):
  auto_bind (default true)   --auto-map-bindings            | -fauto-bind-uniforms
  shift b N [space S]        --shift-UBO-binding N [S]      | -fubo-binding-base N  (every space only)
  shift t N [space S]        --shift-texture-binding N [S]  | -ftexture-binding-base N  (SRVs: textures and
                                                                 read-only buffers; glslang's HLSL mapping puts
                                                                 StructuredBuffer/ByteAddressBuffer/Buffer in t)
  shift s N [space S]        --shift-sampler-binding N [S]  | -fsampler-binding-base N
  shift u N [space S]        --shift-UAV-binding N [S]      | -fuav-binding-base N
(glslang's --shift-ssbo-binding / --shift-image-binding and glslc's -fssbo-/-fimage-binding-base do not apply to HLSL
with the register-class mapping: the four above are the whole mapping.) Without an equivalent, so the tool is
skipped for that file and the skip is counted and printed:
  a shift for one space                    glslc (its *-binding-base options apply to every space)
  global_uniform (-fvk-bind-globals)       both (glslangValidator's --resource-set-binding by name does not take
                                           `$Global`, --set-default-uniform-block is GLSL -R only; glslc has none)
  combined_image_samplers                  both (--auto-sampled-textures / -fauto-combined-image-sampler drop every
                                           sampler, which is not kiln's pairing by register number)
  a shift with [[vk::binding]] in the file both (glslang shifts attributed bindings too; kiln and DXC never do)

Expected differences (docs/bindings.md) are keyed by construct in EXPECTED below, never by file name.

usage: differential_test.py <kiln executable> <kiln source dir> [--corpus DIR] [--jobs N] [--verbose]"""
import argparse
import concurrent.futures
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time

# ---------------------------------------------------------------------------------------------------------------
# Expected differences, keyed by construct (a regular expression over the stage's source, comments removed, its
# includes followed). `tools`: what glslangValidator and glslc do with it; kiln builds every one of them.
#   "reject"        both tools fail to compile the stage: kiln builds more (counted, not a failure).
#   "global_block"  the tools compile it, but as a `$Global` uniform buffer in set 0 where kiln has a push-constant
#                   block of the same size: the test asserts exactly that shape of difference.
#   "numbers_used_only"  recognised by its shape, not by a pattern: the same resources, and every binding that
#                   differs is an automatic one (its name has no register or [[vk::binding]] in the source) that the
#                   tool numbers exactly as many lower than kiln as kiln's pass layout holds automatic resources
#                   below it that this stage does not use. glslang's automatic numbering leaves those out (so the
#                   tools give one resource different bindings in the stages of one pass); kiln's counts them, as
#                   docs/bindings.md says.
# A tool that stops behaving as listed (builds a construct it rejected, or keeps a push constant) fails the test:
# the table and docs/bindings.md are then out of date.
EXPECTED = [
    {"construct": "DXC push-constant spelling `[[vk::push_constant]] T name;` (T a struct type)",
     "pattern": re.compile(r"\[\[[^\]]*\bvk\s*::\s*push_constant\b[^\]]*\]\]\s*(?:\[\[[^\]]*\]\]\s*)*"
                           r"(?!ConstantBuffer\b)[A-Za-z_]\w*\s+[A-Za-z_]\w*\s*;"),
     "tools": "global_block"},
    {"construct": "an attribute list `[[vk::binding(0), vk::push_constant]]` (glslang 12 takes one attribute per group)",
     "pattern": re.compile(r"\[\[(?:[^\](,]|\([^)]*\))*,"),
     "tools": "reject"},
    {"construct": "HLSL 2021 intrinsics select(c, a, b), and(a, b), or(a, b)",
     "pattern": re.compile(r"(?<![\w.])(select|and|or)\s*\("), "unless_declared": True,
     "tools": "reject"},
    # glslang lexes `0.` as a float and leaves `xxxx` a word; it takes `1.0.xxx` and `0.5f.rr`, which are compared
    # as usual (docs/bindings.md lists them with the integer form, which kiln rewrites alike).
    {"construct": "swizzle of an integer literal (`0.xxxx`, `1.xx`)",
     "pattern": re.compile(r"(?<![\w.])\d+\.(?:[xyzw]{1,4}|[rgba]{1,4})(?!\w)"),
     "tools": "reject"},
    {"construct": "NonUniformResourceIndex(i) (DXC's NonUniform decoration; glslang 12 has no such intrinsic)",
     "pattern": re.compile(r"(?<![\w.])(NonUniformResourceIndex)\s*\("), "unless_declared": True,
     "tools": "reject"},
    {"construct": "a resource bound automatically (no register, no [[vk::binding]]) after one the stage does not use "
                  "(the tools number only what the stage uses, kiln every declared resource: rule 3)",
     "pattern": None, "tools": "numbers_used_only"},
]

KILN_STAGES = {"vertex": "vert", "fragment": "frag", "compute": "comp", "geometry": "geom", "hull": "tesc",
               "domain": "tese"}
CLASS_FLAGS = {  # register class -> (glslangValidator, glslc)
    "b": ("--shift-UBO-binding", "-fubo-binding-base"),
    "t": ("--shift-texture-binding", "-ftexture-binding-base"),
    "s": ("--shift-sampler-binding", "-fsampler-binding-base"),
    "u": ("--shift-UAV-binding", "-fuav-binding-base"),
}
TOOLS = ("glslangValidator", "glslc")


# ---------------------------------------------------------------------------------------------------------------
# A small SPIR-V reader: descriptor bindings and push-constant sizes of the resources an entry point references.
class SpirvError(Exception):
    pass


OP_NAME, OP_ENTRY_POINT, OP_DECORATE, OP_MEMBER_DECORATE = 5, 15, 71, 72
OP_TYPE_INT, OP_TYPE_FLOAT, OP_TYPE_VECTOR, OP_TYPE_MATRIX, OP_TYPE_IMAGE, OP_TYPE_SAMPLER = 21, 22, 23, 24, 25, 26
OP_TYPE_SAMPLED_IMAGE, OP_TYPE_ARRAY, OP_TYPE_RUNTIME_ARRAY, OP_TYPE_STRUCT, OP_TYPE_POINTER = 27, 28, 29, 30, 32
OP_TYPE_BOOL, OP_TYPE_ACCELERATION_STRUCTURE = 20, 5341
OP_CONSTANT, OP_SPEC_CONSTANT, OP_FUNCTION, OP_FUNCTION_END, OP_FUNCTION_CALL, OP_VARIABLE = 43, 50, 54, 56, 57, 59
DEC_ROW_MAJOR, DEC_COL_MAJOR, DEC_ARRAY_STRIDE, DEC_MATRIX_STRIDE, DEC_BLOCK, DEC_BUFFER_BLOCK = 4, 5, 6, 7, 2, 3
DEC_BINDING, DEC_DESCRIPTOR_SET, DEC_OFFSET = 33, 34, 35
SC_UNIFORM_CONSTANT, SC_UNIFORM, SC_PUSH_CONSTANT, SC_STORAGE_BUFFER = 0, 2, 9, 12
DIM_BUFFER, DIM_SUBPASS_DATA = 5, 6
# Where an instruction inside a function names a pointer (operand indices after the opcode word, result type and
# result id included): what "the entry point references a variable" means here.
POINTER_OPERANDS = {
    60: (2,),      # OpImageTexelPointer: image
    61: (2,),      # OpLoad: pointer
    62: (0,),      # OpStore: pointer
    63: (0, 1),    # OpCopyMemory: target, source
    65: (2,), 66: (2,),  # OpAccessChain, OpInBoundsAccessChain: base
    67: (2,), 70: (2,),  # OpPtrAccessChain, OpInBoundsPtrAccessChain: base
    68: (2,),      # OpArrayLength: structure
    83: (2,),      # OpCopyObject
    228: (0,),     # OpAtomicStore: pointer
}
POINTER_OPERANDS.update({op: (2,) for op in range(227, 243) if op != 228})  # OpAtomicLoad ... OpAtomicXor
POINTER_OPERANDS.update({318: (2,), 319: (0,)})  # OpAtomicFlagTestAndSet, OpAtomicFlagClear


def read_string(words):
    data = struct.pack("<%dI" % len(words), *words)
    return data.split(b"\0", 1)[0].decode("utf-8", "replace")


class Module:
    def __init__(self, data):
        if len(data) % 4 or len(data) < 20:
            raise SpirvError("not a whole number of words")
        words = struct.unpack("<%dI" % (len(data) // 4), data)
        if words[0] != 0x07230203:
            raise SpirvError("bad magic number")
        self.names, self.decorations, self.member_decorations = {}, {}, {}
        self.types, self.constants, self.variables, self.entry_points = {}, {}, {}, []
        self.functions = {}  # id -> {"calls": set, "pointers": set}
        function = None
        at = 5
        while at < len(words):
            count, opcode = words[at] >> 16, words[at] & 0xFFFF
            if count == 0 or at + count > len(words):
                raise SpirvError("truncated instruction at word %d" % at)
            ops = words[at + 1:at + count]
            at += count
            if opcode == OP_NAME:
                self.names[ops[0]] = read_string(ops[1:])
            elif opcode == OP_ENTRY_POINT:
                name = read_string(ops[2:])
                name_words = len(name.encode("utf-8")) // 4 + 1
                self.entry_points.append({"model": ops[0], "function": ops[1], "name": name,
                                          "interface": list(ops[2 + name_words:])})
            elif opcode == OP_DECORATE:
                self.decorations.setdefault(ops[0], {})[ops[1]] = list(ops[2:])
            elif opcode == OP_MEMBER_DECORATE:
                self.member_decorations.setdefault((ops[0], ops[1]), {})[ops[2]] = list(ops[3:])
            elif opcode in (OP_TYPE_BOOL, OP_TYPE_INT, OP_TYPE_FLOAT, OP_TYPE_VECTOR, OP_TYPE_MATRIX, OP_TYPE_IMAGE,
                            OP_TYPE_SAMPLER, OP_TYPE_SAMPLED_IMAGE, OP_TYPE_ARRAY, OP_TYPE_RUNTIME_ARRAY,
                            OP_TYPE_STRUCT, OP_TYPE_POINTER, OP_TYPE_ACCELERATION_STRUCTURE):
                self.types[ops[0]] = (opcode, list(ops[1:]))
            elif opcode in (OP_CONSTANT, OP_SPEC_CONSTANT):
                self.constants[ops[1]] = ops[2] if len(ops) > 2 else 0
            elif opcode == OP_VARIABLE and function is None:
                self.variables[ops[1]] = {"type": ops[0], "storage": ops[2]}
            elif opcode == OP_FUNCTION:
                function = self.functions.setdefault(ops[1], {"calls": set(), "pointers": set()})
            elif opcode == OP_FUNCTION_END:
                function = None
            elif function is not None:
                if opcode == OP_FUNCTION_CALL:
                    function["calls"].add(ops[2])
                    function["pointers"].update(ops[3:])
                for index in POINTER_OPERANDS.get(opcode, ()):
                    if index < len(ops):
                        function["pointers"].add(ops[index])

    def entry_point(self, name):
        for entry in self.entry_points:
            if entry["name"] == name:
                return entry
        raise SpirvError("no entry point named %r (has %s)" % (name, [e["name"] for e in self.entry_points]))

    def referenced_variables(self, entry):
        """Global variables the functions reachable from the entry point name as pointers."""
        seen, todo, pointers = set(), [entry["function"]], set()
        while todo:
            f = todo.pop()
            if f in seen or f not in self.functions:
                continue
            seen.add(f)
            pointers |= self.functions[f]["pointers"]
            todo.extend(self.functions[f]["calls"])
        return sorted(v for v in pointers if v in self.variables)

    def decoration(self, target, decoration):
        values = self.decorations.get(target, {}).get(decoration)
        return None if values is None else (values[0] if values else True)

    def type_size(self, type_id, member_of=None):
        """The size of a block member's type, as its block's offsets and strides lay it out."""
        opcode, ops = self.types[type_id]
        if opcode in (OP_TYPE_INT, OP_TYPE_FLOAT):
            return ops[0] // 8
        if opcode == OP_TYPE_BOOL:
            return 4
        if opcode == OP_TYPE_VECTOR:
            return ops[1] * self.type_size(ops[0])
        if opcode == OP_TYPE_MATRIX:
            struct_id, member = member_of
            decorations = self.member_decorations.get((struct_id, member), {})
            stride = decorations[DEC_MATRIX_STRIDE][0]
            column_type = self.types[ops[0]][1]
            return stride * (column_type[1] if DEC_ROW_MAJOR in decorations else ops[1])
        if opcode == OP_TYPE_ARRAY:
            return self.decoration(type_id, DEC_ARRAY_STRIDE) * self.constants[ops[1]]
        if opcode == OP_TYPE_RUNTIME_ARRAY:
            return 0
        if opcode == OP_TYPE_STRUCT:
            return self.struct_size(type_id)
        raise SpirvError("no size for type %d (opcode %d)" % (type_id, opcode))

    def struct_size(self, struct_id):
        """The end of the last member (SPIRV-Cross's declared size: no padding after it)."""
        size = 0
        for member, member_type in enumerate(self.types[struct_id][1]):
            offset = self.member_decorations.get((struct_id, member), {}).get(DEC_OFFSET, [0])[0]
            size = max(size, offset + self.type_size(member_type, (struct_id, member)))
        return size

    def resources(self, entry_name):
        """([resource], [push-constant block sizes]) of the variables the entry point references. A resource is a
        dict: set, binding, kind, names (the variable's and its type's OpName), and for a uniform buffer its block's
        size and member count. Kinds are kiln's (reflect.cpp): uniform_buffer, storage_buffer, texture (sampled
        images), storage_image, uniform_texel_buffer and storage_texel_buffer (images of dimension Buffer), sampler,
        combined_image_sampler, input_attachment."""
        found, push = [], []
        for variable in self.referenced_variables(self.entry_point(entry_name)):
            info = self.variables[variable]
            storage, pointee = self.types[info["type"]][1]
            if storage not in (SC_UNIFORM_CONSTANT, SC_UNIFORM, SC_STORAGE_BUFFER, SC_PUSH_CONSTANT):
                continue
            base = pointee
            while self.types[base][0] in (OP_TYPE_ARRAY, OP_TYPE_RUNTIME_ARRAY):
                base = self.types[base][1][0]
            opcode, ops = self.types[base]
            if storage == SC_PUSH_CONSTANT:
                push.append(self.struct_size(base))
                continue
            if storage == SC_UNIFORM_CONSTANT:
                if opcode == OP_TYPE_IMAGE:
                    if ops[1] == DIM_SUBPASS_DATA:
                        kind = "input_attachment"
                    elif ops[1] == DIM_BUFFER:
                        kind = "storage_texel_buffer" if ops[5] == 2 else "uniform_texel_buffer"
                    else:
                        kind = "storage_image" if ops[5] == 2 else "texture"
                elif opcode == OP_TYPE_SAMPLER:
                    kind = "sampler"
                elif opcode == OP_TYPE_SAMPLED_IMAGE:
                    kind = "combined_image_sampler"
                elif opcode == OP_TYPE_ACCELERATION_STRUCTURE:
                    kind = "acceleration_structure"
                else:
                    raise SpirvError("UniformConstant variable %d of type opcode %d" % (variable, opcode))
            elif storage == SC_STORAGE_BUFFER or self.decoration(base, DEC_BUFFER_BLOCK):
                kind = "storage_buffer"
            elif self.decoration(base, DEC_BLOCK):
                kind = "uniform_buffer"
            else:
                raise SpirvError("Uniform variable %d is neither a Block nor a BufferBlock" % variable)
            resource = {"set": self.decoration(variable, DEC_DESCRIPTOR_SET),
                        "binding": self.decoration(variable, DEC_BINDING), "kind": kind,
                        "names": {self.names.get(variable, ""), self.names.get(base, "")} - {""}}
            if kind == "uniform_buffer":
                resource["size"], resource["members"] = self.struct_size(base), len(ops)
            found.append(resource)
        return found, sorted(push)


# ---------------------------------------------------------------------------------------------------------------
# The corpus: headers (corpus_test.cpp's format) and sources.
def parse_corpus(directory):
    shaders = []
    for name in sorted(os.listdir(directory)):
        path = os.path.join(directory, name)
        if not name.endswith(".hlsl") or not os.path.isfile(path):
            continue
        header = {}
        with open(path, encoding="utf-8") as text:
            for line in text:
                if not line.startswith("// "):
                    break
                if ": " in line:
                    key, value = line[3:].rstrip("\n").split(": ", 1)
                    header[key] = value
        stages = {}
        for word in header.get("stages", "").split():
            stage, value = word.split("=", 1)
            if ":" in value:
                source, entry = value.split(":", 1)
                stages[stage] = {"source": os.path.join(directory, source), "entry": entry}
            else:
                stages[stage] = {"source": path, "entry": value}
        shaders.append({"name": name, "path": path, "header": header, "stages": stages,
                        "bindings": json.loads(header["option"]) if "option" in header else {}})
    return shaders


def without_comments(text):
    text = re.sub(r"/\*.*?\*/", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def source_with_includes(path, seen=None):
    """The stage's text with every `#include "x"` it reaches appended (relative to the including file)."""
    seen = set() if seen is None else seen
    path = os.path.realpath(path)
    if path in seen or not os.path.isfile(path):
        return ""
    seen.add(path)
    text = without_comments(open(path, encoding="utf-8").read())
    for include in re.findall(r'^\s*#\s*include\s*"([^"]+)"', text, re.M):
        text += "\n" + source_with_includes(os.path.join(os.path.dirname(path), include), seen)
    return text


def constructs_in(text):
    found = []
    for expected in EXPECTED:
        if expected["pattern"] is None:
            continue
        for match in expected["pattern"].finditer(text):
            if expected.get("unless_declared"):
                # A shader that declares its own `select` (`float3 select(...)`, or a variable) keeps it: its uses
                # are not the intrinsic, and the tools compile them.
                name = re.escape(match.group(1))
                declared = [d for d in re.finditer(r"([A-Za-z_]\w*)\s+" + name + r"\b", text)
                            if d.group(1) not in ("return", "else", "case", "do")]
                if declared:
                    continue
            found.append(expected)
            break
    return found


# ---------------------------------------------------------------------------------------------------------------
# The tools' command lines.
def tool_options(bindings, text):
    """{tool: [flags]} for the file's bindings, or {tool: "why not"} where a tool has no equivalent."""
    flags = {"glslangValidator": ["--target-env", "vulkan1.1", "--hlsl-iomap", "--hlsl-enable-16bit-types"],
             "glslc": ["--target-env=vulkan1.1", "-fhlsl-iomap", "-fhlsl-16bit-types"]}
    skip = {}
    if bindings.get("auto_bind", True):
        flags["glslangValidator"].append("--auto-map-bindings")
        flags["glslc"].append("-fauto-bind-uniforms")
    if bindings.get("combined_image_samplers"):
        skip["glslangValidator"] = skip["glslc"] = "combined_image_samplers has no equivalent"
    if "global_uniform" in bindings:
        skip["glslangValidator"] = skip["glslc"] = "global_uniform (-fvk-bind-globals) has no equivalent"
    shifts = bindings.get("shifts", [])
    if shifts and re.search(r"\[\[\s*vk::binding\s*\(", text):
        skip["glslangValidator"] = skip["glslc"] = "glslang shifts [[vk::binding]] bindings, kiln does not"
    # Every-space shifts first: glslangValidator's per-set values win over them, as kiln's do.
    for shift in sorted(shifts, key=lambda s: "space" in s):
        validator, glslc = CLASS_FLAGS[shift["register"]]
        if "space" in shift:
            flags["glslangValidator"] += [validator, str(shift["shift"]), str(shift["space"])]
            skip.setdefault("glslc", "a shift for one space (glslc's *-binding-base apply to every space)")
        else:
            flags["glslangValidator"] += [validator, str(shift["shift"])]
            flags["glslc"] += [glslc, str(shift["shift"])]
    return {tool: skip.get(tool, flags[tool]) for tool in TOOLS}


def run_tool(tool, flags, stage, source, entry, output):
    if tool == "glslangValidator":
        command = (["glslangValidator", "-V", "-D", "-S", KILN_STAGES[stage], "-e", entry] + flags +
                   [source, "-o", output])
    else:
        command = (["glslc", "-x", "hlsl", "-fshader-stage=" + KILN_STAGES[stage], "-fentry-point=" + entry] + flags +
                   [source, "-o", output])
    result = subprocess.run(command, capture_output=True, text=True)
    log = (result.stdout + result.stderr).strip()
    return result.returncode == 0 and os.path.exists(output), command, log


def run_kiln(kiln, shader, work):
    """({stage: ([resource], [push sizes])} of the variant without keywords, the pass layout's resources, log), or
    (None, None, log) when the build fails."""
    pack = {"name": "corpus", "passes": [{"name": "P", "source": shader["path"], "stages": {
        stage: (s["entry"] if s["source"] == shader["path"] else {"source": s["source"], "entry": s["entry"]})
        for stage, s in shader["stages"].items()}}]}
    if shader["bindings"]:
        pack["bindings"] = shader["bindings"]
    if "targets" in shader["header"]:
        pack["targets"] = shader["header"]["targets"].split()
    pack_file = os.path.join(work, "pack.json")
    with open(pack_file, "w", encoding="utf-8") as out:
        json.dump(pack, out)
    try:
        result = subprocess.run([kiln, "build", pack_file, "-o", os.path.join(work, "out"), "--no-cache", "-q",
                                 "-j", "1"], capture_output=True, text=True)
    except OSError as error:
        return None, None, "cannot run %s: %s" % (kiln, error)
    manifest = os.path.join(work, "out", "corpus.manifest.json")
    if result.returncode != 0 or not os.path.exists(manifest):
        return None, None, (result.stdout + result.stderr).strip()
    m = json.load(open(manifest, encoding="utf-8"))
    variants = [v for v in m["passes"][0]["variants"] if not v["keywords"]]
    if not variants:
        return {}, [], "no variant without keywords, which is what the tools compiled"
    per_stage = {}
    for stage, binary in variants[0]["binaries"].items():
        reflection = m["reflections"][m["binaries"][binary]["reflection"]]
        per_stage[stage] = (reflection["resources"], sorted(p["size"] for p in reflection["push_constants"]))
    return per_stage, m["passes"][0]["layout"]["resources"], ""


def explicit_names(text):
    """Names declared with `register(...)` or `[[vk::binding(...)]]`: the rest are bound automatically."""
    names = set(re.findall(r"([A-Za-z_]\w*)\s*(?:\[[^\]]*\])?\s*:\s*register\s*\(", text))
    for declaration in re.findall(r"\[\[\s*vk::binding\s*\([^)]*\)\s*\]\]([^;{]*)", text):
        names.update(re.findall(r"([A-Za-z_]\w*)\s*(?:\[[^\]]*\])?\s*(?::|$)", declaration.strip())[-1:])
    return names


def triples(resources):
    return sorted((r["set"], r["binding"], r["kind"]) for r in resources)


def compare_stage(tool, tool_resources, tool_push, kiln_resources, kiln_push, kiln_layout, text):
    """None when the tool's and kiln's bindings of a stage agree, the EXPECTED entry when they differ as it says, or
    a message that says how they differ."""
    constructs = constructs_in(text)
    expected = None
    global_block = next((e for e in constructs if e["tools"] == "global_block"), None)
    if global_block and tool_push:
        return "%s made the DXC push-constant spelling a push-constant block: EXPECTED is out of date" % tool
    if global_block and kiln_push:
        # The tool has one more resource, the $Global uniform buffer in set 0 holding the struct (as large as kiln's
        # push-constant block when it holds nothing else); everything else is compared as usual.
        block = [r for r in tool_resources
                 if r["kind"] == "uniform_buffer" and "$Global" in r["names"] and r["set"] == 0]
        if len(block) != 1 or (block[0]["members"] == 1 and [block[0]["size"]] != kiln_push) or \
                any("$Global" == k["name"] for k in kiln_resources):
            return ("the DXC push-constant spelling: expected %s to give a $Global uniform buffer in set 0 of %s "
                    "bytes and kiln a push-constant block, found %s and kiln push %s" %
                    (tool, kiln_push, [(r["set"], r["binding"], r.get("size")) for r in block], kiln_push))
        tool_resources = [r for r in tool_resources if r is not block[0]]
        tool_push, expected = kiln_push, global_block
    if triples(tool_resources) == triples(kiln_resources) and tool_push == kiln_push:
        return expected
    # Automatic bindings: the tools number only the resources the stage uses, kiln every declared one (rule 3 of
    # docs/bindings.md), so past a resource that another stage uses, the tool's automatic numbers are lower.
    unmatched, moved = list(kiln_resources), []
    for r in tool_resources:
        match = next((k for k in unmatched
                      if (k["set"], k["kind"]) == (r["set"], r["kind"]) and k["name"] in r["names"]), None)
        if match is None:
            break
        unmatched.remove(match)
        if match["binding"] != r["binding"]:
            moved.append((r, match))
    else:
        explicit = explicit_names(text)
        used = {k["name"] for k in kiln_resources}

        def compacted(k):
            """kiln's binding less the automatic resources of the pass numbered below it that this stage does not
            use: the number glslang gives when it leaves them out."""
            return k["binding"] - sum(1 for other in kiln_layout
                                      if other["set"] == k["set"] and other["binding"] < k["binding"] and
                                      other["name"] not in used and other["name"] not in explicit)
        if not unmatched and tool_push == kiln_push and moved and all(
                k["name"] not in explicit and r["binding"] == compacted(k) for r, k in moved):
            return next(e for e in EXPECTED if e["tools"] == "numbers_used_only")

    def describe(resources):
        return sorted((r["set"], r["binding"], r["kind"], r.get("name") or "/".join(sorted(r["names"])))
                      for r in resources)
    return ("%s and kiln disagree on the bindings:\n    %s: %s push %s\n    kiln: %s push %s" %
            (tool, tool, describe(tool_resources), tool_push, describe(kiln_resources), kiln_push))


# ---------------------------------------------------------------------------------------------------------------
def check_file(kiln, shader, scratch):
    """Everything about one corpus file: builds, comparisons, failures (strings)."""
    work = tempfile.mkdtemp(prefix=os.path.splitext(shader["name"])[0] + ".", dir=scratch)
    r = {"name": shader["name"], "failures": [], "notes": [], "tool_built": {}, "tool_skipped": {},
         "agreed": 0, "expected": [], "compared": 0, "kiln_more": set()}
    texts = {stage: source_with_includes(s["source"]) for stage, s in shader["stages"].items()}
    options = tool_options(shader["bindings"], "\n".join(texts.values()))
    tool_outputs = {}
    for tool in TOOLS:
        if isinstance(options[tool], str):
            r["tool_skipped"][tool] = options[tool]
            continue
        built = True
        for stage, s in shader["stages"].items():
            output = os.path.join(work, "%s.%s.spv" % (tool, stage))
            ok, command, log = run_tool(tool, options[tool], stage, s["source"], s["entry"], output)
            rejecting = [e for e in constructs_in(texts[stage]) if e["tools"] == "reject"]
            if ok and rejecting:
                r["failures"].append("%s: %s built the %s stage, which has %s: EXPECTED says the tools reject it" %
                                     (shader["name"], tool, stage, rejecting[0]["construct"]))
            if not ok:
                built = False
                if rejecting:
                    r["kiln_more"].add(rejecting[0]["construct"])
                else:
                    r["notes"].append("%s: %s fails on the %s stage (no construct of EXPECTED): %s" %
                                      (shader["name"], tool, stage, log.splitlines()[-1] if log else "no output"))
                continue
            tool_outputs[(tool, stage)] = output
        r["tool_built"][tool] = built
    kiln_stages, kiln_layout, kiln_log = run_kiln(kiln, shader, work)
    r["kiln_built"] = kiln_stages is not None
    if kiln_stages is None:
        for tool, built in r["tool_built"].items():
            if built:  # Rule A
                r["failures"].append("%s: %s builds it, kiln does not:\n%s" % (shader["name"], tool, kiln_log[-2000:]))
        if not any(r["tool_built"].values()):
            r["notes"].append("%s: kiln does not build it either:\n%s" % (shader["name"], kiln_log[-2000:]))
        return r
    if kiln_log:
        r["failures"].append("%s: %s" % (shader["name"], kiln_log))
        return r
    for (tool, stage), output in sorted(tool_outputs.items()):  # Rule B
        try:
            tool_resources, tool_push = Module(open(output, "rb").read()).resources(shader["stages"][stage]["entry"])
        except (SpirvError, KeyError, IndexError, struct.error) as error:
            r["failures"].append("%s: cannot read %s's SPIR-V of the %s stage: %s" %
                                 (shader["name"], tool, stage, error))
            continue
        r["compared"] += 1
        outcome = compare_stage(tool, tool_resources, tool_push, *kiln_stages[stage], kiln_layout, texts[stage])
        if outcome is None:
            r["agreed"] += 1
        elif isinstance(outcome, dict):
            r["expected"].append((tool, stage, outcome["construct"]))
        else:
            r["failures"].append("%s, %s stage: %s" % (shader["name"], stage, outcome))
    return r


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("kiln")
    parser.add_argument("source_dir")
    parser.add_argument("--corpus", help="the corpus directory (default: <source dir>/tests/corpus)")
    parser.add_argument("--jobs", type=int, default=2, help="files checked at once (default 2)")
    parser.add_argument("--verbose", action="store_true")
    args = parser.parse_args()
    corpus = os.path.abspath(args.corpus or os.path.join(args.source_dir, "tests", "corpus"))
    for program in TOOLS:
        if not shutil.which(program):
            print("FAIL: %s is not installed (.ci/install-deps installs it)" % program)
            return 1
    started = time.monotonic()
    shaders = parse_corpus(corpus)
    scratch = tempfile.mkdtemp(prefix="kiln-differential.")
    try:
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            results = list(pool.map(lambda s: check_file(os.path.abspath(args.kiln), s, scratch), shaders))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    failures = [f for r in results for f in r["failures"]]
    built = {tool: sum(bool(r["tool_built"].get(tool)) for r in results) for tool in TOOLS}
    skipped = {tool: [(r["name"], r["tool_skipped"][tool]) for r in results if tool in r["tool_skipped"]]
               for tool in TOOLS}
    kiln_built = sum(r["kiln_built"] for r in results)
    kiln_more = [(r["name"], c) for r in results for c in sorted(r["kiln_more"])]
    for tool in TOOLS:
        for name, why in skipped[tool]:
            print("skip: %s for %s: %s" % (tool, name, why))
    for name, construct in kiln_more:
        print("expected: kiln builds %s, the tools reject it: %s" % (name, construct))
    for r in results:
        for tool, stage, construct in r["expected"]:
            print("expected: %s %s stage, %s differs from kiln as documented: %s" % (r["name"], stage, tool, construct))
        for note in r["notes"]:
            print("note: " + note)
        if args.verbose:
            print("%s: tools built %s, kiln %s, %d of %d stage comparisons agreed" %
                  (r["name"], r["tool_built"], r["kiln_built"], r["agreed"], r["compared"]))
    stage_differences = sum(len(r["expected"]) for r in results)
    print("%d files: glslangValidator built %d (skipped %d), glslc built %d (skipped %d), kiln built %d; reflection "
          "agreed on %d of %d stage comparisons; expected differences %d (%d files kiln builds and the tools reject, "
          "%d stage comparisons that differ as documented); %.1f s" %
          (len(results), built["glslangValidator"], len(skipped["glslangValidator"]), built["glslc"],
           len(skipped["glslc"]), kiln_built, sum(r["agreed"] for r in results), sum(r["compared"] for r in results),
           len(kiln_more) + stage_differences, len(kiln_more), stage_differences, time.monotonic() - started))
    # The comparison must cover the corpus, not a few files of it.
    for tool in TOOLS:
        if len(skipped[tool]) * 4 > len(results):
            failures.append("%s was skipped for %d of %d files: the test no longer covers most of the corpus" %
                            (tool, len(skipped[tool]), len(results)))
    if len(results) < 40:
        failures.append("only %d corpus files in %s" % (len(results), corpus))
    for failure in failures:
        print("FAIL: " + failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
