// Times one stage of a build into the build report (the summary's "stage times", and when each ran).
#pragma once

#include <chrono>
#include <string>

#include "kiln/build.hpp"

namespace kiln {

using StageClock = std::chrono::steady_clock;

inline double ms_since_start(const BuildReport& report, StageClock::time_point at) {
  return std::chrono::duration<double, std::milli>(at - report.started).count();
}

// A stage whose start and end are not one scope's (preprocessing streams into the compile stage).
inline void record_stage(BuildReport& report, std::string stage, StageClock::time_point start, StageClock::time_point end) {
  report.timings.push_back({std::move(stage), std::chrono::duration<double, std::milli>(end - start).count(),
                            ms_since_start(report, start), ms_since_start(report, end)});
}

class StageTimer {
 public:
  StageTimer(BuildReport& report, std::string stage) : report_(report), stage_(std::move(stage)), start_(StageClock::now()) {}
  ~StageTimer() { record_stage(report_, std::move(stage_), start_, StageClock::now()); }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  BuildReport& report_;
  std::string stage_;
  StageClock::time_point start_;
};

}  // namespace kiln
