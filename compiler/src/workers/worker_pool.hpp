// SPDX-License-Identifier: Apache-2.0
// Long-lived compiler worker processes. glslang 12 segfaults on some inputs and has unbounded
// recursion; a worker that crashes, hangs past the timeout or runs out of memory costs one job,
// never the build. Each worker compiles many jobs (start-up costs 30-50 ms).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "kiln/result.hpp"
#include "kiln/defaults.hpp"
#include "workers/compile_job.hpp"
#include "workers/job_runner.hpp"

namespace kiln {

struct WorkerLimits {
  std::chrono::milliseconds job_timeout = defaults::kWorkerTimeout;
  uint64_t memory_limit_mb = defaults::kWorkerMemoryLimitMb;  // RLIMIT_AS of each worker
  std::string frontend{kDefaultFrontend};  // the front end the workers compile with (frontend_names())
  // BuildOptions::interruption: also waited on (`interrupt_fds`) and asked (`interrupted`) before each job is handed
  // out; once it says true, the jobs not handed out end as Cancelled and those in flight finish.
  std::vector<int> interrupt_fds;
  std::function<bool()> interrupted;
};

class WorkerPool final : public JobRunner {
 public:
  WorkerPool(std::filesystem::path executable, unsigned workers, WorkerLimits limits);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Runs every job; `on_done(index, outcome)` is called on this thread as each finishes. It may append
  // follow-up jobs to `jobs` (run next, in the same workers); `index` always indexes `jobs`.
  void run(std::vector<CompileJob>& jobs, const std::function<void(size_t, WorkerOutcome)>& on_done,
           const ExternalWork* external = nullptr) override;
  unsigned spawned() const override { return spawned_; }
  std::vector<WorkerActivity> activity() const override;

 private:
  struct Worker;
  Result<void> spawn(Worker& worker);
  void stop(Worker& worker, bool kill_now);

  std::filesystem::path executable_;
  unsigned count_;
  WorkerLimits limits_;
  std::vector<Worker*> workers_;
  unsigned spawned_ = 0;
};

// Finds kiln-worker: $KILN_WORKER, then next to the running executable, then the build tree.
std::filesystem::path default_worker_executable();

// The worker process's main loop (kiln-worker's main). `before_job` sees each job before it runs: the test suite's
// fault-injecting worker (tests/support/fault_worker.cpp) passes one; the shipped worker passes none, so no fault
// injection is compiled into it.
int worker_main(int argc, char** argv, void (*before_job)(CompileJob& job) = nullptr);

}  // namespace kiln
