// SPDX-License-Identifier: Apache-2.0
// A SPIR-V module as a list of instructions, for the front end's small edits of glslang's output that keep DXC's
// meaning (nonuniform.cpp, dxc_semantics.cpp): parse, look up definitions and names, add capabilities,
// extensions, decorations and types where the module layout wants them, write back. Not a general IR: the edits
// are few and local, and spirv-val checks every module kiln builds after them.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace kiln::spirv_edit {

struct Instruction {
  std::vector<uint32_t> words;  // the opcode word first
  uint32_t op() const { return words[0] & 0xffff; }
  // A literal string operand starting at word `at`.
  std::string string_at(size_t at) const;
};

Instruction make(uint32_t op, std::vector<uint32_t> operands);
Instruction make_with_string(uint32_t op, std::vector<uint32_t> operands, std::string_view text);

class Module {
 public:
  // Nothing when the words are not a well-formed instruction stream.
  static std::optional<Module> parse(const std::vector<uint32_t>& words);
  std::vector<uint32_t> words() const;

  std::vector<Instruction>& instructions() { return instructions_; }
  const std::vector<Instruction>& instructions() const { return instructions_; }
  uint32_t version() const { return header_[1]; }

  // Result id -> index of the instruction that defines it (recomputed on each call: edits move instructions).
  std::map<uint32_t, size_t> definitions() const;
  // The OpName of an id; empty when none.
  std::string name_of(uint32_t id) const;

  uint32_t new_id() { return header_[3]++; }
  void add_capability(uint32_t capability);
  void add_extension(std::string_view name);
  // An OpName or OpMemberName, after the other debug instructions.
  void add_debug_name(Instruction name);
  // After the last annotation (or before the first type when the module has none).
  void add_annotation(Instruction annotation);
  // A type or global, after the last declaration before the first function.
  void add_declaration(Instruction declaration);
  // Removes every OpName, OpMemberName and annotation whose target is one of `ids`.
  void forget(const std::vector<uint32_t>& ids);

 private:
  size_t end_of_header(bool with_annotations) const;
  std::array<uint32_t, 5> header_{};
  std::vector<Instruction> instructions_;
};

// Whether an opcode has a result type and a result id (words 1 and 2), or a result id only (word 1).
bool has_result_type(uint32_t op);
bool has_result(uint32_t op);
// The id an instruction defines, or 0.
uint32_t result_of(const Instruction& in);

}  // namespace kiln::spirv_edit
