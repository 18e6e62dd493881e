// SPDX-License-Identifier: Apache-2.0
// libFuzzer harness: every other decoder of bytes from outside, one target per first byte of the input.
//   0: a compile record (the cache's and the remote's payloads, a worker's answer): decode_output, and the bounded
//      CBOR decoder under it; then the same bytes as a shard's bundle from the remote (decode_shard_bundle);
//   1: a pack definition, 2: a scene profile (the JSON parsers, from a file as kiln reads them; the scene is also
//      resolved against the pack's features and materials);
//   3: command-line option values, one per line: -D values, then a --fvk-*-shift pair and a --fvk-bind-globals pair
//      from the first two lines, and --shard: the first line as its value, the next lines as the scheduler's
//      variables (SLURM_ARRAY_TASK_ID, ..._COUNT, ..._MIN, ..._MAX, CI_NODE_INDEX, CI_NODE_TOTAL, ...).
// Findings: a crash, an escaped exception (the parsers report to their sink and never throw; decode_output throws
// only std::exception), ASan/UBSan.
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <unistd.h>

#include "common/compile_result.hpp"
#include "definition/definition.hpp"
#include "driver/shard_bundle.hpp"

namespace {

void write(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::vector<std::string> lines_of(std::string_view text) {
  std::vector<std::string> lines;
  std::stringstream in{std::string(text)};
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path directory = [] {
    std::string pattern = (std::filesystem::temp_directory_path() / "kiln-fuzz-inputs-XXXXXX").string();
    if (!::mkdtemp(pattern.data())) std::abort();
    return std::filesystem::path(pattern);
  }();
  static const bool cleanup = std::atexit([] {
    std::error_code ec;
    std::filesystem::remove_all(directory, ec);
  }) == 0;
  (void)cleanup;
  if (size == 0) return 0;
  const std::string_view input(reinterpret_cast<const char*>(data) + 1, size - 1);
  kiln::DiagnosticSink sink;
  switch (data[0] % 4) {
    case 0:
      try {
        kiln::JobOutput output = kiln::decode_output(std::vector<uint8_t>(input.begin(), input.end()));
        if (output.messages.size() > input.size()) std::abort();  // more messages than bytes: not bounded
      } catch (const std::exception&) {
        // a malformed record: what the cache and the remote turn into a miss
      }
      {
        // decode_shard_bundle reports, never throws; what it accepts is bounded by its bytes.
        const kiln::Result<kiln::ShardBundle> bundle = kiln::decode_shard_bundle(input, 1);
        if (bundle && (bundle->sources.size() > input.size() || bundle->outputs.size() > input.size())) std::abort();
      }
      break;
    case 1: {
      write(directory / "p.pack.json", input);
      auto pack = kiln::load_pack_definition(directory / "p.pack.json", kiln::ReadLimits{}, sink);
      if (pack)
        for (const auto& pass : pack->passes)
          if (pass.name.find('/') != std::string::npos) std::abort();  // a pass name that is a path
      break;
    }
    case 2: {
      write(directory / "s.json", input);
      auto scene = kiln::load_scene_profile(directory / "s.json", kiln::ReadLimits{}, sink);
      if (scene) kiln::resolve_scene_profile(*scene, R"({"fog": {"on": ["FOG"], "off": []}})", {}, sink);
      break;
    }
    case 3: {
      const std::vector<std::string> lines = lines_of(input);
      kiln::parse_command_line_defines(lines, sink);
      kiln::BindingOptions options;
      if (lines.size() >= 2) {
        kiln::parse_command_line_shift(kiln::RegisterClass::T, lines[0], lines[1], options, sink);
        kiln::parse_command_line_globals(lines[0], lines[1], options, sink);
      }
      for (const auto& [key, shift] : options.shifts)
        if (shift > kiln::kMaxBindingNumber) std::abort();  // over the limit the pack also keeps
      if (!lines.empty()) {
        static constexpr const char* kVariables[] = {"SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT", "SLURM_ARRAY_TASK_MIN",
                                                     "SLURM_ARRAY_TASK_MAX", "CI_NODE_INDEX", "CI_NODE_TOTAL",
                                                     "JOB_COMPLETION_INDEX", "KILN_SHARD_COUNT"};
        auto environment = [&](const char* name) -> const char* {
          for (size_t i = 0; i < std::size(kVariables); ++i)
            if (std::string_view(name) == kVariables[i]) return i + 1 < lines.size() ? lines[i + 1].c_str() : nullptr;
          return nullptr;
        };
        const kiln::Result<kiln::Shard> shard = kiln::parse_shard_option(lines[0], environment);
        if (shard && (shard->count == 0 || shard->index >= shard->count))
          std::abort();  // accepted a shard outside its count
      }
      break;
    }
  }
  size_t printed = 0;
  for (const kiln::Diagnostic& diagnostic : sink.diagnostics()) printed += kiln::format_diagnostic(diagnostic).size();
  if (printed == SIZE_MAX) std::abort();  // keeps the formatting
  return 0;
}
