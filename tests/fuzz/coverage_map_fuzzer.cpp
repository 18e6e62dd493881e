// SPDX-License-Identifier: Apache-2.0
// libFuzzer harness: kiln::read_coverage_map (kiln/coverage_map.hpp) over fuzzed module bytes, as a game's renderer
// or kiln test's reads a pack's SPIR-V. The reader ships in the library games link and returns errors, never throws.
// Findings: a crash, an escaped exception, ASan/UBSan (a read past the module), and a map larger than its module:
// every probe is a store of the module and every line one of its OpLines, so a map that holds more of either than
// the module has words was copied, not read (20,000 stores in a block of 20,000 lines were once 400 million lines).
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "kiln/coverage_map.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  kiln::Result<std::optional<kiln::CoverageMap>> map = kiln::read_coverage_map(bytes);
  if (!map || !*map) return 0;
  const size_t words = size / 4;
  size_t lines = 0;
  for (const kiln::CoverageProbe& probe : (*map)->probes) {
    if (probe.word >= kiln::kCoverageBufferWords) std::abort();  // the reader promises words inside the buffer
    for (const auto& [file, line] : probe.lines)
      if (file >= (*map)->files.size()) std::abort();
    lines += probe.lines.size();
  }
  if ((*map)->probes.size() > words || lines > words || (*map)->files.size() > words) std::abort();
  return 0;
}
