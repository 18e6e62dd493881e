// SPDX-License-Identifier: Apache-2.0
// kiln-fault-worker: the compiler worker with fault injection, for the test suite only (the shipped kiln-worker has
// none). Tests that need a worker to hang, run out of memory, crash or throw point BuildOptions::worker_executable
// (or a WorkerPool) at it (KILN_FAULT_WORKER_PATH):
//  - a source containing "kiln-fault: hang" or "kiln-fault: oom" makes it hang or exhaust its memory;
//  - a preprocessing job whose entry file holds "kiln-fault: crash-preprocess" crashes it (SIGSEGV), as a
//    preprocessor bug would;
//  - a source naming kiln_fault_throw (an identifier, so it survives preprocessing) makes it throw, as a library bug
//    would;
//  - a back end whose module names a function KilnFaultCrashBackEnd crashes it (SIGSEGV), as a SPIRV-Tools bug
//    would; one whose module names KilnFaultInvalidModule loses its Location decorations, as a front-end bug would,
//    so that spirv-val rejects it; one whose module names KilnFaultTruncatedModule ends in the middle of an
//    instruction, so that the optimizer cannot parse it.
#include <algorithm>
#include <chrono>
#include <csignal>
#include <stdexcept>
#include <string_view>
#include <thread>
#include <vector>

#include "workers/compile_job.hpp"
#include "workers/worker_pool.hpp"

namespace {

using kiln::CompileJob;
using kiln::JobKind;

void inject_fault(CompileJob& job) {
  if (job.kind == JobKind::Preprocess && job.files && !job.files->empty() &&
      job.files->front().text.find("kiln-fault: crash-preprocess") != std::string::npos)
    std::raise(SIGSEGV);
  if (job.source.find("kiln-fault: hang") != std::string::npos)
    for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
  if (job.source.find("kiln_fault_throw") != std::string::npos) throw std::runtime_error("injected worker exception");
  if (job.source.find("kiln-fault: oom") != std::string::npos) {
    std::vector<std::vector<char>> hog;
    for (;;) hog.emplace_back(64 << 20, 'x');
  }
  std::string_view module(reinterpret_cast<const char*>(job.spirv.data()), job.spirv.size() * 4);
  if (job.kind == JobKind::BackEnd && module.find("KilnFaultCrashBackEnd") != std::string_view::npos) std::raise(SIGSEGV);
  if (job.kind == JobKind::BackEnd && module.find("KilnFaultInvalidModule") != std::string_view::npos) {
    constexpr uint32_t kOpDecorate = 71, kDecorationLocation = 30;
    std::vector<uint32_t> kept(job.spirv.begin(), job.spirv.begin() + 5);
    for (size_t i = 5; i < job.spirv.size();) {
      const uint32_t words = std::max<uint32_t>(job.spirv[i] >> 16, 1);
      const bool location = (job.spirv[i] & 0xffffu) == kOpDecorate && words >= 3 && job.spirv[i + 2] == kDecorationLocation;
      if (!location) kept.insert(kept.end(), job.spirv.begin() + i, job.spirv.begin() + std::min(i + words, job.spirv.size()));
      i += words;
    }
    job.spirv = std::move(kept);
  }
  if (job.kind == JobKind::BackEnd && module.find("KilnFaultTruncatedModule") != std::string_view::npos)
    job.spirv.back() += 4u << 16;  // the last instruction (OpFunctionEnd) now claims words past the end
}

}  // namespace

int main(int argc, char** argv) { return kiln::worker_main(argc, argv, inject_fault); }
