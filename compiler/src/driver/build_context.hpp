// SPDX-License-Identifier: Apache-2.0
// What the stages of one build share, and all they share: where diagnostics go, where a compiler worker's death
// leaves its reproducer, the progress callback, and the build's clock (each stage's time, for the summary). A stage
// takes the context and the inputs it reads, never the whole BuildOptions; what it makes, its counts included, it
// returns. Only build_pack writes the build report.
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "kiln/build.hpp"

namespace kiln {

using StageClock = std::chrono::steady_clock;

class BuildTrace;  // driver/build_trace.hpp
// A stage's slice in the trace (driver/build_trace.cpp).
void trace_stage(BuildTrace& trace, const std::string& stage, StageClock::time_point start, StageClock::time_point end);

struct BuildContext {
  explicit BuildContext(DiagnosticSink& diagnostics, std::filesystem::path reproducer_dir = {},
                        std::function<void(size_t done, size_t total, size_t cache_hits)> on_progress = {})
      : sink(diagnostics), reproducers(std::move(reproducer_dir)), progress(std::move(on_progress)) {}
  BuildContext(const BuildContext&) = delete;
  BuildContext& operator=(const BuildContext&) = delete;

  DiagnosticSink& sink;
  std::filesystem::path reproducers;  // <output>/kiln-ice
  std::function<void(size_t done, size_t total, size_t cache_hits)> progress;  // may be empty
  StageClock::time_point started = StageClock::now();  // stage times count from here
  std::vector<StageTiming> timings;
  BuildTrace* trace = nullptr;  // --trace: every stage, job and lookup as a slice (driver/build_trace.hpp)

  double ms_since_start(StageClock::time_point at) const {
    return std::chrono::duration<double, std::milli>(at - started).count();
  }
  // A stage whose start and end are not one scope's (preprocessing streams into the compile stage).
  void record_stage(std::string stage, StageClock::time_point start, StageClock::time_point end) {
    if (trace) trace_stage(*trace, stage, start, end);
    timings.push_back({std::move(stage), std::chrono::duration<double, std::milli>(end - start).count(),
                       ms_since_start(start), ms_since_start(end)});
  }
  void report_progress(size_t done, size_t total, size_t cache_hits) const {
    if (progress) progress(done, total, cache_hits);
  }
};

// Times one stage, from its construction to the end of its scope.
class StageTimer {
 public:
  StageTimer(BuildContext& build, std::string stage) : build_(build), stage_(std::move(stage)), start_(StageClock::now()) {}
  ~StageTimer() { build_.record_stage(std::move(stage_), start_, StageClock::now()); }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  BuildContext& build_;
  std::string stage_;
  StageClock::time_point start_;
};

}  // namespace kiln
