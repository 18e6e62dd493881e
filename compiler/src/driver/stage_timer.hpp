// Times one stage of a build into the build report (the summary's "stage times").
#pragma once

#include <chrono>
#include <string>

#include "kiln/build.hpp"

namespace kiln {

class StageTimer {
 public:
  using Clock = std::chrono::steady_clock;
  StageTimer(BuildReport& report, std::string stage) : report_(report), stage_(std::move(stage)), start_(Clock::now()) {}
  ~StageTimer() {
    report_.timings.push_back({stage_, std::chrono::duration<double, std::milli>(Clock::now() - start_).count()});
  }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  BuildReport& report_;
  std::string stage_;
  Clock::time_point start_;
};

}  // namespace kiln
