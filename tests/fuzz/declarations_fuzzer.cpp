// SPDX-License-Identifier: Apache-2.0
// libFuzzer harness: the declaration scanner (stage 1) and the includer's confinement over fuzzed HLSL.
//
// Input: an entry file and one include file, split at the first "\n//--include--\n" (no split: no include
// file). The entry is written to <dir>/S.hlsl and the include file to <dir>/lib/Inc.hlsl, with roots <dir>
// and <dir>/lib, and scan_declarations() runs over them; every diagnostic is formatted as the CLI prints it.
// Findings: a crash, an exception (scan_declarations reports to its sink and never throws), ASan/UBSan, or a
// file read from outside the roots.
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include <unistd.h>

#include "declarations/declarations.hpp"

namespace {

void write(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

bool below(const std::filesystem::path& path, const std::filesystem::path& root) {
  const std::string p = path.string(), r = root.string() + "/";
  return p.rfind(r, 0) == 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path directory = [] {
    std::string pattern = (std::filesystem::temp_directory_path() / "kiln-fuzz-declarations-XXXXXX").string();
    if (!::mkdtemp(pattern.data())) std::abort();
    std::filesystem::create_directories(std::filesystem::path(pattern) / "lib");
    return std::filesystem::weakly_canonical(pattern);
  }();
  // Registered once `directory` exists, so that it runs before `directory` is destroyed.
  static const bool cleanup = std::atexit([] {
    std::error_code ec;
    std::filesystem::remove_all(directory, ec);
  }) == 0;
  (void)cleanup;

  const std::string_view input(reinterpret_cast<const char*>(data), size);
  constexpr std::string_view kSplit = "\n//--include--\n";
  const size_t split = input.find(kSplit);
  write(directory / "S.hlsl", input.substr(0, split));
  std::error_code ec;
  std::filesystem::remove(directory / "lib/Inc.hlsl", ec);
  if (split != std::string_view::npos) write(directory / "lib/Inc.hlsl", input.substr(split + kSplit.size()));

  kiln::IncludeRoots roots({directory, directory / "lib"});
  kiln::SourceSet sources;
  kiln::DiagnosticSink sink;
  auto declarations = kiln::scan_declarations(directory / "S.hlsl", roots, kiln::ReadLimits{}, sources, sink);
  for (const auto& [path, file] : sources.files)
    if (!below(path, directory)) std::abort();  // read a file outside the include roots
  if (declarations)
    for (const auto& file : declarations->files)
      if (!below(file, directory)) std::abort();
  size_t printed = 0;
  for (const kiln::Diagnostic& diagnostic : sink.diagnostics()) printed += kiln::format_diagnostic(diagnostic).size();
  if (printed == SIZE_MAX) std::abort();  // keeps the formatting
  return 0;
}
