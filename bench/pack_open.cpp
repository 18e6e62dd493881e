// SPDX-License-Identifier: Apache-2.0
// What a game pays for a pack, through the C API only (kiln/kiln_reader.h), so that the same source times any
// build of the reader: open and close, select by keyword ids, and the first use of each variant's fragment SPIR-V.
//
//   kiln-pack-open PACK...                 Google Benchmark over each pack (--benchmark_* flags as usual)
//   kiln-pack-open --rss PACK              RSS after open, after one variant's first use, after every variant's
//
// bench/pack_open.sh runs both on the default pack and on a 10x synthetic one (kiln-synthetic-pack) and, for the
// record, on an older reader and the pack it reads; bench/REPORT.md has the numbers.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "kiln/kiln_reader.h"
#include "select_requests.hpp"

namespace {

[[noreturn]] void die(const char* what, const kiln_error& error) {
  std::fprintf(stderr, "%s: %s: %s\n", what, error.file, error.message);
  std::exit(1);
}

kiln_pack* open_pack(const std::string& path) {
  kiln_pack* pack = nullptr;
  kiln_error error;
  if (kiln_pack_open(path.c_str(), &pack, &error) != KILN_OK) die("kiln_pack_open", error);
  return pack;
}


void BM_Open(benchmark::State& state, const std::string& path) {
  for (auto _ : state) {
    kiln_pack* pack = open_pack(path);
    benchmark::DoNotOptimize(pack);
    kiln_pack_close(pack);
  }
}

// Each variant's own keywords as ids, in a shuffled order: what a renderer asks for per draw.
void BM_Select(benchmark::State& state, const std::string& path) {
  kiln_pack* pack = open_pack(path);
  const kiln_pass pass = largest_pass(pack);
  const std::vector<std::vector<kiln_keyword>> requests = shuffled_requests(pack, pass);
  size_t i = 0, failed = 0;
  for (auto _ : state) {
    const std::vector<kiln_keyword>& ids = requests[i++ % requests.size()];
    uint32_t variant = 0;
    failed += kiln_select(pack, pass, ids.data(), ids.size(), 0, &variant, nullptr) != KILN_OK;
    benchmark::DoNotOptimize(variant);
  }
  state.counters["failed"] = static_cast<double>(failed);
  kiln_pack_close(pack);
}

// Opens the pack (not timed), then gets every variant's fragment SPIR-V once: the time per first use.
void BM_FirstUse(benchmark::State& state, const std::string& path) {
  size_t uses = 0, bytes = 0;
  for (auto _ : state) {
    state.PauseTiming();
    kiln_pack* pack = open_pack(path);
    const kiln_pass pass = largest_pass(pack);
    state.ResumeTiming();
    for (uint32_t v = 0; v < kiln_variant_count(pack, pass); ++v) {
      kiln_code code;
      kiln_error error;
      if (kiln_variant_code(pack, pass, v, KILN_STAGE_FRAGMENT, KILN_TARGET_SPIRV, &code, &error) != KILN_OK)
        die("kiln_variant_code", error);
      bytes += code.size;
      ++uses;
    }
    state.PauseTiming();
    kiln_pack_close(pack);
    state.ResumeTiming();
  }
  state.counters["per_use"] = benchmark::Counter(static_cast<double>(uses), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["bytes"] = static_cast<double>(bytes) / static_cast<double>(state.iterations());
}

// "RssAnon: 1234 kB" and "RssFile: ..." of this process, in MiB.
std::string rss() {
  std::ifstream status("/proc/self/status");
  std::string line, out;
  while (std::getline(status, line))
    if (line.starts_with("RssAnon:") || line.starts_with("RssFile:")) {
      const double mib = std::strtod(line.c_str() + 8, nullptr) / 1024.0;
      char text[64];
      std::snprintf(text, sizeof text, "%s%s %.1f MiB", out.empty() ? "" : ", ", line.substr(0, 7).c_str(), mib);
      out += text;
    }
  return out;
}

int report_rss(const std::string& path) {
  std::printf("before open: %s\n", rss().c_str());
  kiln_pack* pack = open_pack(path);
  std::printf("after open: %s\n", rss().c_str());
  const kiln_pass pass = largest_pass(pack);
  kiln_code code;
  kiln_error error;
  if (kiln_variant_code(pack, pass, 0, KILN_STAGE_FRAGMENT, KILN_TARGET_SPIRV, &code, &error) != KILN_OK) die("kiln_variant_code", error);
  std::printf("after one variant's fragment SPIR-V: %s\n", rss().c_str());
  for (uint32_t v = 0; v < kiln_variant_count(pack, pass); ++v)
    if (kiln_variant_code(pack, pass, v, KILN_STAGE_FRAGMENT, KILN_TARGET_SPIRV, &code, &error) != KILN_OK) die("kiln_variant_code", error);
  std::printf("after all %u variants' fragment SPIR-V: %s\n", kiln_variant_count(pack, pass), rss().c_str());
  kiln_pack_close(pack);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--rss") == 0) return report_rss(argv[2]);
  benchmark::Initialize(&argc, argv);
  if (argc < 2) {
    std::fprintf(stderr, "usage: kiln-pack-open [--benchmark flags] PACK... | kiln-pack-open --rss PACK\n");
    return 2;
  }
  for (int i = 1; i < argc; ++i) {
    const std::string path = argv[i];
    benchmark::RegisterBenchmark(("open/" + path).c_str(), BM_Open, path)->Unit(benchmark::kMicrosecond);
    benchmark::RegisterBenchmark(("select/" + path).c_str(), BM_Select, path);
    benchmark::RegisterBenchmark(("first_use/" + path).c_str(), BM_FirstUse, path)->Unit(benchmark::kMillisecond);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
