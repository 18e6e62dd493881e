// SPDX-License-Identifier: Apache-2.0
// The reading half of shader code coverage: which words of the coverage buffer a module sets, and the source lines
// of each. The writing half is the build's (compiler/src/coverage/instrument.cpp). The module may be hostile: every
// count and operand is checked before it is read.
#include "kiln/coverage_map.hpp"

#include <glslang/SPIRV/spirv.hpp>

#include <cstring>
#include <map>
#include <set>

namespace kiln {
namespace {

// The NUL-terminated string in `count` words (OpString's and OpName's last operand); the caller has checked that the
// instruction holds them.
std::string literal_string(const uint32_t* words, size_t count) {
  std::string out;
  for (size_t w = 0; w < count; ++w)
    for (int b = 0; b < 4; ++b) {
      const char c = static_cast<char>((words[w] >> (8 * b)) & 0xff);
      if (c == 0) return out;
      out.push_back(c);
    }
  return out;
}

}  // namespace

Result<std::optional<CoverageMap>> read_coverage_map(std::string_view bytes) {
  if (bytes.size() % 4 != 0 || bytes.size() < 20) return failure("not a SPIR-V module (" + std::to_string(bytes.size()) + " bytes)");
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), bytes.size());
  if (words[0] != spv::MagicNumber) return failure("not a SPIR-V module (no magic number)");

  // One pass over the instructions: names, strings, decorations and constants are all declared before the functions.
  std::map<uint32_t, std::string> strings, names;
  std::map<uint32_t, uint32_t> sets, bindings, constants;
  struct Block {
    std::vector<std::pair<uint32_t, uint32_t>> lines;  // string id, line
    std::vector<uint32_t> probe_chains;                // the constant ids that index the buffer
  };
  std::vector<Block> blocks;
  std::map<uint32_t, uint32_t> chain_index;  // an access chain's result id -> its last index's id (buffer chains only)
  std::set<uint32_t> buffer_variables;       // filled once the functions start
  bool in_functions = false;
  for (size_t at = 5; at < words.size();) {
    const uint32_t count = words[at] >> 16, op = words[at] & 0xffff;
    if (count == 0 || at + count > words.size()) return failure("a truncated SPIR-V instruction at word " + std::to_string(at));
    const uint32_t* w = &words[at];
    auto operand = [&](uint32_t i) { return i < count ? w[i] : 0; };
    // Both name an id and then hold a string of at least one word: a shorter one would make count - 2 wrap.
    if ((op == spv::OpString || op == spv::OpName) && count < 3)
      return failure("an Op" + std::string(op == spv::OpString ? "String" : "Name") + " of " + std::to_string(count) +
                     " words (it needs 3 or more) at word " + std::to_string(at));
    switch (op) {
      case spv::OpString: strings[operand(1)] = literal_string(w + 2, count - 2); break;
      case spv::OpName: names[operand(1)] = literal_string(w + 2, count - 2); break;
      case spv::OpDecorate:
        if (operand(2) == spv::DecorationDescriptorSet) sets[operand(1)] = operand(3);
        if (operand(2) == spv::DecorationBinding) bindings[operand(1)] = operand(3);
        break;
      case spv::OpConstant:
        if (count == 4) constants[operand(2)] = operand(3);
        break;
      case spv::OpFunction:
        if (!in_functions) {
          in_functions = true;
          for (const auto& [id, name] : names)
            if (name == kCoverageBufferName && sets.count(id) && sets[id] == kCoverageSet && bindings.count(id) &&
                bindings[id] == kCoverageBinding)
              buffer_variables.insert(id);
        }
        break;
      case spv::OpLabel: blocks.emplace_back(); break;
      case spv::OpLine:
        if (!blocks.empty() && count >= 3) blocks.back().lines.emplace_back(operand(1), operand(2));
        break;
      case spv::OpAccessChain:
        if (count >= 5 && buffer_variables.count(operand(3))) chain_index[operand(2)] = w[count - 1];
        break;
      case spv::OpStore:
        if (auto chain = chain_index.find(operand(1)); chain != chain_index.end() && !blocks.empty())
          blocks.back().probe_chains.push_back(chain->second);
        break;
      default: break;
    }
    at += count;
  }
  if (buffer_variables.empty()) return std::optional<CoverageMap>{};

  // The map is as large as what the module holds: each OpLine goes to one probe. kiln stores once per block; when a
  // block stores more than once (another writer's module, or a hostile one), its lines go to its first probe and the
  // others carry none: they run when the first does. Copying the lines to every probe made 20,000 stores in a block
  // of 20,000 lines 400 million pairs (std::bad_alloc after 2.5 GB from a 1 MB module).
  CoverageMap map;
  std::map<uint32_t, uint32_t> file_index;  // string id -> index into map.files
  for (const Block& block : blocks) {
    for (size_t p = 0; p < block.probe_chains.size(); ++p) {
      auto word = constants.find(block.probe_chains[p]);
      if (word == constants.end()) return failure("a coverage store whose index is not a constant");
      if (word->second >= kCoverageBufferWords)
        return failure("a coverage word (" + std::to_string(word->second) + ") past the buffer's " + std::to_string(kCoverageBufferWords));
      CoverageProbe probe{word->second, {}};
      for (size_t l = 0; p == 0 && l < block.lines.size(); ++l) {
        const auto& [string_id, line] = block.lines[l];
        auto file = strings.find(string_id);
        if (file == strings.end()) return failure("an OpLine whose file is not an OpString");
        auto [found, added] = file_index.try_emplace(string_id, static_cast<uint32_t>(map.files.size()));
        if (added) map.files.push_back(file->second);
        if (probe.lines.empty() || probe.lines.back() != std::make_pair(found->second, line)) probe.lines.emplace_back(found->second, line);
      }
      map.probes.push_back(std::move(probe));
    }
  }
  return std::optional<CoverageMap>{std::move(map)};
}

}  // namespace kiln
