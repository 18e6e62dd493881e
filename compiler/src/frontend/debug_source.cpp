// SPDX-License-Identifier: Apache-2.0
#include <glslang/SPIRV/spirv.hpp>

#include "frontend/debug_source.hpp"

#include <algorithm>
#include <map>
#include <optional>

#include "frontend/spirv_module.hpp"

namespace kiln {
namespace {

using spirv_edit::Instruction;

// An instruction holds at most 65535 words: OpSource's four fixed words and the NUL leave this much text per
// instruction; OpSourceContinued carries the rest.
constexpr size_t kSourceBytes = (65535 - 4) * 4 - 1;
constexpr size_t kContinuedBytes = (65535 - 1) * 4 - 1;

}  // namespace

void keep_original_sources(std::vector<uint32_t>& spirv, const std::vector<SourceText>& sources) {
  if (sources.empty()) return;
  std::optional<spirv_edit::Module> module = spirv_edit::Module::parse(spirv);
  if (!module) return;
  std::vector<Instruction>& instructions = module->instructions();
  auto first = std::find_if(instructions.begin(), instructions.end(), [](const Instruction& in) { return in.op() == spv::OpSource; });
  if (first == instructions.end() || first->words.size() < 3) return;
  const uint32_t language = first->words[1], version = first->words[2];
  std::map<std::string, uint32_t> strings;  // the OpLines' file names
  for (const Instruction& in : instructions)
    if (in.op() == spv::OpString && in.words.size() > 2) strings.emplace(in.string_at(2), in.words[1]);
  const size_t at = static_cast<size_t>(first - instructions.begin());
  std::erase_if(instructions, [](const Instruction& in) { return in.op() == spv::OpSource || in.op() == spv::OpSourceContinued; });
  std::vector<Instruction> added;
  for (const SourceText& source : sources) {
    auto [name, fresh] = strings.emplace(std::string(source.name), 0);
    if (fresh) {
      name->second = module->new_id();
      added.push_back(spirv_edit::make_with_string(spv::OpString, {name->second}, source.name));
    }
    // A literal string ends at its NUL: a file with one is kept up to it.
    const std::string_view text = source.text.substr(0, source.text.find('\0'));
    added.push_back(spirv_edit::make_with_string(spv::OpSource, {language, version, name->second}, text.substr(0, kSourceBytes)));
    for (size_t from = kSourceBytes; from < text.size(); from += kContinuedBytes)
      added.push_back(spirv_edit::make_with_string(spv::OpSourceContinued, {}, text.substr(from, kContinuedBytes)));
  }
  // After every OpString (an OpSource may name any of them; no forward references), else where OpSource was.
  size_t insert_at = std::min(at, instructions.size());
  for (size_t i = 0; i < instructions.size(); ++i)
    if (instructions[i].op() == spv::OpString || instructions[i].op() == spv::OpSourceExtension) insert_at = i + 1;
  instructions.insert(instructions.begin() + static_cast<long>(insert_at), added.begin(), added.end());
  spirv = module->words();
}

}  // namespace kiln
