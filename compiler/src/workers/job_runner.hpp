// What the build's scheduler needs of the compiler workers: run jobs, report each outcome. The worker pool
// implements it with processes; tests implement it in-process.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "workers/compile_job.hpp"

namespace kiln {

struct WorkerOutcome {
  enum class Kind { Done, Crashed, TimedOut, OutOfMemory, Failed } kind = Kind::Done;
  JobOutput output;    // when Done
  std::string detail;  // "killed by signal 11 (Segmentation fault)", ...
};

class JobRunner {
 public:
  virtual ~JobRunner() = default;
  // Runs every job; `on_done(index, outcome)` is called on the calling thread as each finishes. It may append
  // follow-up jobs to `jobs` (run next); `index` always indexes `jobs`.
  virtual void run(std::vector<CompileJob>& jobs, const std::function<void(size_t, WorkerOutcome)>& on_done) = 0;
  // Worker processes started so far (for the build summary).
  virtual unsigned spawned() const = 0;
};

}  // namespace kiln
