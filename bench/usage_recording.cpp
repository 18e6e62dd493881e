// SPDX-License-Identifier: Apache-2.0
// What usage recording (docs/usage.md) costs a selection: kiln_select by keyword ids through the C API and
// PackReader::select by names, each with recording off and on, over every variant of the pack's largest pass in a
// shuffled order. Run interleaved: kiln-usage-recording PACK --benchmark_enable_random_interleaving=true
// --benchmark_repetitions=10 (bench/REPORT.md, "Usage recording").
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "kiln/kiln_reader.h"
#include "kiln/pack_reader.hpp"
#include "select_requests.hpp"

namespace {

std::string g_pack;

void BM_SelectByIds(benchmark::State& state) {
  kiln_pack* pack = nullptr;
  kiln_error error;
  if (kiln_pack_open(g_pack.c_str(), &pack, &error) != KILN_OK) {
    state.SkipWithError(error.message);
    return;
  }
  if (state.range(0)) kiln_pack_record_usage(pack, "/tmp/kiln-usage-bench-ids.json", nullptr, 0, &error);
  const kiln_pass pass = largest_pass(pack);
  const std::vector<std::vector<kiln_keyword>> requests = shuffled_requests(pack, pass);
  size_t i = 0;
  for (auto _ : state) {
    const std::vector<kiln_keyword>& ids = requests[i++ % requests.size()];
    uint32_t variant = 0;
    kiln_select(pack, pass, ids.data(), ids.size(), 0, &variant, nullptr);
    benchmark::DoNotOptimize(variant);
  }
  kiln_pack_close(pack);  // writes the log when recording (not timed: after the loop)
}

void BM_SelectByNames(benchmark::State& state) {
  kiln::PackReader reader = kiln::PackReader::open(g_pack);
  if (state.range(0)) reader.record_usage({"/tmp/kiln-usage-bench-names.json", {}});
  std::string pass;
  size_t most = 0;
  for (const std::string& p : reader.passes())
    if (reader.variant_count(p) > most) most = reader.variant_count(pass = p);
  std::vector<std::vector<std::string>> requests;
  for (size_t v = 0; v < most; ++v) requests.push_back(reader.variant(pass, v).keywords);
  std::shuffle(requests.begin(), requests.end(), std::mt19937(2026));
  size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(reader.select(pass, requests[i++ % requests.size()]).index);
}

// Every thread selecting the same variant at once (a hot material in every worker's draw list): with recording on,
// every selection increments that variant's one counter, so the threads' cores pass its cache line between them.
// One pack for all the threads, opened and closed by thread 0 (the timing loop's start and end are barriers).
void BM_SelectOneVariantFromEveryThread(benchmark::State& state) {
  static kiln_pack* pack = nullptr;
  static kiln_pass pass = 0;
  static std::vector<kiln_keyword> ids;
  if (state.thread_index() == 0) {
    kiln_error error;
    if (kiln_pack_open(g_pack.c_str(), &pack, &error) != KILN_OK) {
      std::fprintf(stderr, "%s: %s\n", g_pack.c_str(), error.message);
      std::exit(1);
    }
    if (state.range(0)) kiln_pack_record_usage(pack, "/tmp/kiln-usage-bench-threads.json", nullptr, 0, &error);
    pass = largest_pass(pack);
    ids = shuffled_requests(pack, pass).front();
  }
  for (auto _ : state) {
    uint32_t variant = 0;
    kiln_select(pack, pass, ids.data(), ids.size(), 0, &variant, nullptr);
    benchmark::DoNotOptimize(variant);
  }
  if (state.thread_index() == 0) {
    kiln_pack_close(pack);
    pack = nullptr;
  }
}

}  // namespace

BENCHMARK(BM_SelectOneVariantFromEveryThread)->ArgName("recording")->Arg(0)->Arg(1)->Threads(1)->Threads(2)->UseRealTime();
BENCHMARK(BM_SelectByIds)->ArgName("recording")->Arg(0)->Arg(1);
BENCHMARK(BM_SelectByNames)->ArgName("recording")->Arg(0)->Arg(1);

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (argc != 2) {
    std::fprintf(stderr, "usage: kiln-usage-recording [--benchmark flags] PACK\n");
    return 2;
  }
  g_pack = argv[1];
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
