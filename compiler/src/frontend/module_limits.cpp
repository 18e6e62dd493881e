// SPDX-License-Identifier: Apache-2.0
#include "frontend/module_limits.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <functional>
#include <map>
#include <optional>
#include <regex>
#include <sstream>

#include "frontend/hlsl_compat.hpp"

namespace kiln {
namespace {

constexpr uint64_t kMaxThreadsXY = 1024, kMaxThreadsZ = 64, kMaxThreadsPerGroup = 1024;
constexpr uint64_t kMaxGroupsharedBytes = 32768;

// The file and line of byte `offset` of preprocessed text, following its #line directives.
FrontendMessage located(std::string_view text, size_t offset, const std::string& source_name, std::string message) {
  std::string path = source_name;
  int line = 1;
  size_t at = 0;
  while (at < offset && at < text.size()) {
    size_t end = text.find('\n', at);
    if (end == std::string_view::npos || end >= offset) break;
    // `#line N` or `#line N "file"`: the next line is line N (of that file).
    std::string_view directive = text.substr(at, end - at);
    auto skip_blanks = [&] { while (!directive.empty() && (directive[0] == ' ' || directive[0] == '\t')) directive.remove_prefix(1); };
    skip_blanks();
    bool is_line = directive.starts_with('#');
    if (is_line) {
      directive.remove_prefix(1);
      skip_blanks();
      is_line = directive.starts_with("line") && directive.size() > 4 && (directive[4] == ' ' || directive[4] == '\t');
    }
    size_t digits = 0;
    if (is_line) {
      directive.remove_prefix(4);
      skip_blanks();
      while (digits < directive.size() && digits < 9 && std::isdigit(static_cast<unsigned char>(directive[digits]))) ++digits;
    }
    if (digits > 0) {
      line = std::stoi(std::string(directive.substr(0, digits)));
      directive.remove_prefix(digits);
      skip_blanks();
      if (directive.starts_with('"') && directive.find('"', 1) != std::string_view::npos)
        path = std::string(directive.substr(1, directive.find('"', 1) - 1));
    } else {
      ++line;
    }
    at = end + 1;
  }
  const size_t line_start = offset == 0 ? 0 : text.rfind('\n', offset - 1) + 1;
  return FrontendMessage{Severity::Error, path, line, std::move(message), static_cast<int>(offset - line_start) + 1};
}

}  // namespace

FrontendMessage located_in_source(std::string_view text, size_t offset, const std::string& source_name, std::string message) {
  return located(text, offset, source_name, std::move(message));
}

std::optional<FrontendMessage> locate_location_conflict(const std::string& message, std::string_view source,
                                                        const std::string& source_name) {
  static const std::regex conflict(R"(conflicting (input|output) location assignment at location (\d{1,9}))");
  std::smatch found;
  if (!std::regex_search(message, found, conflict)) return std::nullopt;
  const std::string location = found[2];
  // `vk :: location ( N )`, as the preprocessor spaces it or not; at most two wanted.
  std::vector<size_t> stated;
  for (size_t at = source.find("location"); at != std::string_view::npos && stated.size() < 2; at = source.find("location", at + 8)) {
    size_t cursor = at + 8;
    auto blanks = [&] { while (cursor < source.size() && (source[cursor] == ' ' || source[cursor] == '\t')) ++cursor; };
    blanks();
    if (cursor >= source.size() || source[cursor] != '(') continue;
    ++cursor;
    blanks();
    if (source.substr(cursor, location.size()) != location) continue;
    cursor += location.size();
    blanks();
    if (cursor >= source.size() || source[cursor] != ')') continue;
    size_t before = at;
    while (before > 0 && (source[before - 1] == ' ' || source[before - 1] == '\t')) --before;
    if (before >= 2 && source.substr(before - 2, 2) == "::") stated.push_back(at);
  }
  if (stated.empty()) return std::nullopt;
  FrontendMessage out = located(source, stated.back(), source_name,
      "'location' : two " + std::string(found[1]) + "s of this stage are at location " + location +
      ", which Vulkan forbids (spirv-val: \"conflicting " + std::string(found[1]) + " location assignment\"): give each its own [[vk::location]]" + (stated.size() == 1 ? ", or none to the others (glslang numbers them from 0)" : ""));
  out.column = 0;  // the preprocessed text's spacing is not the file's: the driver finds the quoted word
  return out;
}

namespace {

std::optional<FrontendMessage> judge(uint64_t x, uint64_t y, uint64_t z, const std::function<FrontendMessage(std::string)>& at) {
  const std::string written = "numthreads(" + std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) + ")";
  if (x == 0 || y == 0 || z == 0) return at(written + ": each dimension of a thread group must be at least 1");
  if (x > kMaxThreadsXY || y > kMaxThreadsXY || z > kMaxThreadsZ)
    return at(written + ": a thread group is at most 1024 x 1024 x 64 (D3D's limits, which DXC enforces; Vulkan, GL "
                        "and Metal guarantee no more)");
  if (x * y * z > kMaxThreadsPerGroup)
    return at(written + ": " + std::to_string(x * y * z) + " threads in a group, over the 1024 that D3D, Metal and "
                        "DXC allow (Vulkan guarantees 128)");
  return std::nullopt;
}

bool is_name_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// The offset of `word` as a whole word at or after `from`, followed (after blanks) by `next`; npos when none.
size_t find_word(std::string_view text, std::string_view word, char next, size_t from = 0) {
  for (size_t at = text.find(word, from); at != std::string_view::npos; at = text.find(word, at + 1)) {
    if (at > 0 && is_name_char(text[at - 1])) continue;
    size_t after = at + word.size();
    if (after < text.size() && is_name_char(text[after])) continue;
    while (after < text.size() && (text[after] == ' ' || text[after] == '\t' || text[after] == '\n' || text[after] == '\r')) ++after;
    if (after < text.size() && text[after] == next) return at;
  }
  return std::string_view::npos;
}

// The offset of the numthreads attribute of `entry` (the last `[numthreads(...)]` before `entry(`), or npos; its
// arguments' text in `arguments`. A plain scan: no regular expression runs over a source of any size.
size_t numthreads_of(std::string_view source, const std::string& entry, std::string* arguments) {
  const size_t entry_at = find_word(source, entry, '(');
  if (entry_at == std::string_view::npos) return entry_at;
  size_t best = std::string_view::npos;
  for (size_t at = find_word(source, "numthreads", '('); at != std::string_view::npos && at < entry_at;
       at = find_word(source, "numthreads", '(', at + 1)) {
    const size_t open = source.find('(', at), close = source.find(')', open);
    if (close == std::string_view::npos || close > entry_at) break;
    best = at;
    *arguments = std::string(source.substr(open + 1, close - open - 1));
  }
  return best;
}

// Byte size of a SPIR-V type (no padding: a lower bound, which is what a limit check needs).
struct Module {
  std::map<uint32_t, std::vector<uint32_t>> types;  // result id -> the instruction's words
  std::map<uint32_t, uint64_t> constants;          // 32- and 64-bit integer constants
  std::vector<uint32_t> workgroup_pointer_types;    // pointee type ids of Workgroup variables
  std::vector<uint32_t> block_types;                // pointee type ids of Uniform, StorageBuffer, PushConstant variables
  std::map<uint32_t, std::string> names;            // OpName
  std::optional<std::array<uint32_t, 3>> local_size;
};

uint64_t size_of(const Module& module, uint32_t type, int depth = 0) {
  auto it = module.types.find(type);
  if (it == module.types.end() || depth > 64) return 0;
  const std::vector<uint32_t>& w = it->second;
  const uint32_t opcode = w[0] & 0xffffu;
  auto saturating = [](uint64_t a, uint64_t b) { return b != 0 && a > UINT64_MAX / b ? UINT64_MAX : a * b; };
  switch (opcode) {
    case 20: return 1;                                          // OpTypeBool (as stored: 1 byte at least)
    case 21: case 22: return w.size() > 2 ? w[2] / 8 : 4;       // OpTypeInt, OpTypeFloat: width
    case 23: case 24: return w.size() > 3 ? saturating(size_of(module, w[2], depth + 1), w[3]) : 0;  // vector, matrix
    case 28: {                                                  // OpTypeArray: element, length constant
      auto length = w.size() > 3 ? module.constants.find(w[3]) : module.constants.end();
      return length == module.constants.end() ? 0 : saturating(size_of(module, w[2], depth + 1), length->second);
    }
    case 29: return w.size() > 2 ? size_of(module, w[2], depth + 1) : 0;  // OpTypeRuntimeArray: one element
    case 30: {                                                  // OpTypeStruct
      uint64_t total = 0;
      for (size_t i = 2; i < w.size(); ++i) total = std::min<uint64_t>(UINT64_MAX / 2, total + size_of(module, w[i], depth + 1));
      return total;
    }
    default: return 0;
  }
}

Module read_module(const std::vector<uint32_t>& spirv) {
  Module module;
  std::map<uint32_t, uint32_t> pointer_pointee, block_pointee;  // Workgroup / block pointer type -> pointee
  std::vector<uint32_t> workgroup_variable_types, block_variable_types;
  for (size_t i = 5; i < spirv.size();) {
    const uint32_t count = spirv[i] >> 16, opcode = spirv[i] & 0xffffu;
    if (count == 0 || i + count > spirv.size()) break;
    std::vector<uint32_t> w(spirv.begin() + static_cast<long>(i), spirv.begin() + static_cast<long>(i + count));
    if (opcode == 16 && count >= 6 && w[2] == 17) module.local_size = std::array<uint32_t, 3>{w[3], w[4], w[5]};  // LocalSize
    if (opcode >= 20 && opcode <= 30 && count >= 2) module.types[w[1]] = w;
    if (opcode == 32 && count >= 4 && w[2] == 4) pointer_pointee[w[1]] = w[3];  // OpTypePointer Workgroup
    if (opcode == 32 && count >= 4 && (w[2] == 2 || w[2] == 9 || w[2] == 12)) block_pointee[w[1]] = w[3];
    if (opcode == 5 && count >= 3) {  // OpName: a nul-terminated string
      std::string name(reinterpret_cast<const char*>(&w[2]), (count - 2) * 4);
      module.names[w[1]] = name.substr(0, name.find('\0'));
    }
    if (opcode == 43 && count >= 4) module.constants[w[2]] = count >= 5 ? (uint64_t{w[4]} << 32 | w[3]) : w[3];  // OpConstant
    if (opcode == 59 && count >= 4 && w[3] == 4) workgroup_variable_types.push_back(w[1]);  // OpVariable Workgroup
    if (opcode == 59 && count >= 4 && (w[3] == 2 || w[3] == 9 || w[3] == 12)) block_variable_types.push_back(w[1]);
    i += count;
  }
  for (uint32_t pointer : workgroup_variable_types)
    if (auto it = pointer_pointee.find(pointer); it != pointer_pointee.end()) module.workgroup_pointer_types.push_back(it->second);
  for (uint32_t pointer : block_variable_types)
    if (auto it = block_pointee.find(pointer); it != block_pointee.end()) module.block_types.push_back(it->second);
  return module;
}

}  // namespace

std::vector<FrontendMessage> check_numthreads_source(std::string_view source, const std::string& source_name,
                                                     const std::string& entry) {
  std::string arguments;
  const size_t at = numthreads_of(source, entry, &arguments);
  if (at == std::string_view::npos) return {};
  std::vector<uint64_t> values;
  std::string item;
  std::stringstream in(arguments);
  while (std::getline(in, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t\r\n"));
    item.erase(item.find_last_not_of(" \t\r\n") + 1);
    if (item.empty() || item.find_first_not_of("0123456789") != std::string::npos) return {};  // an expression
    values.push_back(item.size() > 19 ? UINT64_MAX / 4 : std::stoull(item));
  }
  if (values.size() != 3) return {};
  auto at_source = [&](std::string message) { return located(source, at, source_name, std::move(message)); };
  if (auto problem = judge(std::min(values[0], uint64_t{1} << 20), std::min(values[1], uint64_t{1} << 20),
                           std::min(values[2], uint64_t{1} << 20), at_source)) {
    if (values[0] > (uint64_t{1} << 20) || values[1] > (uint64_t{1} << 20) || values[2] > (uint64_t{1} << 20))
      problem->text = "numthreads(" + arguments + "): a thread group is at most 1024 x 1024 x 64 (D3D's limits, which "
                      "DXC enforces; Vulkan, GL and Metal guarantee no more)";
    return {*problem};
  }
  return {};
}

std::vector<FrontendMessage> check_buffer_arrays_source(std::string_view source, const std::string& source_name) {
  static const std::regex declaration(
      R"(\b((?:RW|RasterizerOrdered|Append|Consume)?StructuredBuffer[ \t]{0,64}<[^;{}()]{0,256}>|(?:RW|RasterizerOrdered)?ByteAddressBuffer))"
      R"(\s{1,64}([A-Za-z_]\w{0,255})[ \t]{0,64}\[)");
  std::vector<FrontendMessage> messages;
  // Every match holds StructuredBuffer or ByteAddressBuffer, then a `[` with no `;` between. Most sources have no
  // such array, and std::regex over a whole preprocessed library was 2% of a compile job.
  bool candidate = false;
  for (std::string_view word : {"StructuredBuffer", "ByteAddressBuffer"})
    for (size_t at = source.find(word); at != std::string_view::npos && !candidate; at = source.find(word, at + 1)) {
      const size_t bracket = source.find('[', at), end = source.find(';', at);
      candidate = bracket != std::string_view::npos && bracket < end;
    }
  if (!candidate) return messages;
  const std::string text(source);
  for (const std::smatch& match : file_scope_matches(text, declaration)) {
    if (messages.size() == 16) break;  // each is located from the text's start: a bounded number
    std::string type = match[1];
    type = type.substr(0, type.find('<'));
    while (!type.empty() && (type.back() == ' ' || type.back() == '\t')) type.pop_back();
    // The line from the #line directives; the column from the user's line (the driver finds the quoted name in it:
    // the preprocessed text's spacing is not the file's).
    FrontendMessage& message = messages.emplace_back(located(source, static_cast<size_t>(match.position(2)), source_name,
                               "'" + std::string(match[2]) + "' : an array of " + type + " (DXC: a descriptor array of storage "
                               "buffers) is beyond glslang 12, which " +
                                   (type.find("ByteAddress") != std::string::npos ? std::string("cannot parse it")
                                                                                  : std::string("crashes on an access to it")) +
                                   ": declare one buffer per binding, or compile this shader with DXC"));
    message.column = 0;
  }
  return messages;
}

std::vector<FrontendMessage> check_compute_module(const std::vector<uint32_t>& spirv, std::string_view source,
                                                  const std::string& source_name) {
  const Module module = read_module(spirv);
  std::vector<FrontendMessage> messages;
  auto at_word = [&](std::string_view word) {
    return [&, word](std::string message) {
      const size_t at = source.find(word);
      return located(source, at == std::string_view::npos ? 0 : at, source_name, std::move(message));
    };
  };
  if (module.local_size)
    if (auto problem = judge((*module.local_size)[0], (*module.local_size)[1], (*module.local_size)[2], at_word("numthreads")))
      messages.push_back(*problem);
  uint64_t shared = 0;
  for (uint32_t type : module.workgroup_pointer_types) shared = std::min<uint64_t>(UINT64_MAX / 2, shared + size_of(module, type));
  if (shared > kMaxGroupsharedBytes)
    messages.push_back(at_word("groupshared")("groupshared variables take " + std::to_string(shared) +
                                              " bytes, over the 32768 that D3D and DXC allow (Vulkan guarantees 16384)"));
  return messages;
}

std::vector<FrontendMessage> check_buffer_blocks(const std::vector<uint32_t>& spirv) {
  const Module module = read_module(spirv);
  std::vector<FrontendMessage> messages;
  for (uint32_t type : module.block_types) {
    // An array of blocks (ConstantBuffer<T> b[4]) is several blocks: each is judged.
    uint32_t block = type;
    for (auto it = module.types.find(block); it != module.types.end() && ((it->second[0] & 0xffffu) == 28 || (it->second[0] & 0xffffu) == 29);
         it = module.types.find(block))
      block = it->second[2];
    const uint64_t size = size_of(module, block);
    if (size < (uint64_t{1} << 32)) continue;
    auto name = module.names.find(block);
    messages.push_back({Severity::Error, "", 0,
                        "buffer block '" + (name == module.names.end() ? std::string("?") : name->second) + "' is " +
                            std::to_string(size) + " bytes; a block must be under 4 GiB (SPIR-V offsets are 32-bit)"});
  }
  return messages;
}

}  // namespace kiln
