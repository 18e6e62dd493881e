// SPDX-License-Identifier: Apache-2.0
// What the build's scheduler needs of the compiler workers: run jobs, report each outcome. The worker pool
// implements it with processes; tests implement it in-process.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "workers/compile_job.hpp"

namespace kiln {

// Where and when a worker process ran a job (`kiln build --trace`): its slot, when it was handed out and when its
// answer (or the worker's death) came, and the steps the worker timed, from the job's arrival there (validated:
// bounded, known steps, in order; they may still end past `answered`, and a reader clamps them).
struct JobTiming {
  using Clock = std::chrono::steady_clock;
  unsigned slot = 0;
  Clock::time_point sent, answered;
  std::vector<StepSpan> steps;
  uint64_t steps_elapsed_us = 0;  // the job's time in the worker, from its arrival (the steps end by then)
};

struct WorkerOutcome {
  // Cancelled: never handed out, the build was interrupted (WorkerLimits::interrupted).
  enum class Kind { Done, Crashed, TimedOut, OutOfMemory, Failed, Cancelled } kind = Kind::Done;
  JobOutput output;    // when Done; its `steps` are moved to `timing`
  std::string detail;  // "killed by signal 11 (Segmentation fault)", ...
  std::optional<JobTiming> timing;  // when a worker process ran it
};

// What one worker slot did (the build's timeline): when it started, when it was first given a front or back
// end, and how long it had a job in flight, by kind.
struct WorkerActivity {
  using Clock = std::chrono::steady_clock;
  Clock::time_point spawned, first_compile, last_done;
  bool compiled = false;  // first_compile is set
  Clock::duration preprocessing{}, compiling{};
  Clock::duration preprocessing_before_compile{};  // of `preprocessing`, before first_compile
  size_t jobs = 0;
};

// Work that arrives from outside the jobs (the remote cache's answers): while `pending()`, the runner also waits on
// `fd` (readable when something arrived) and calls `arrived()` on the calling thread, which may append jobs to `jobs`
// as `on_done` may. A runner with no jobs left keeps waiting while `pending()`.
struct ExternalWork {
  int fd = -1;
  std::function<bool()> pending;
  std::function<void()> arrived;
};

class JobRunner {
 public:
  virtual ~JobRunner() = default;
  // Runs every job; `on_done(index, outcome)` is called on the calling thread as each finishes. It may append
  // follow-up jobs to `jobs` (run next); `index` always indexes `jobs`.
  virtual void run(std::vector<CompileJob>& jobs, const std::function<void(size_t, WorkerOutcome)>& on_done,
                   const ExternalWork* external = nullptr) = 0;
  // Worker processes started so far (for the build summary).
  virtual unsigned spawned() const = 0;
  // One entry per worker slot that ran a job; empty for runners without processes.
  virtual std::vector<WorkerActivity> activity() const { return {}; }
};

}  // namespace kiln
