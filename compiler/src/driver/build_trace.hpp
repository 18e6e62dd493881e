// SPDX-License-Identifier: Apache-2.0
// `kiln build --trace FILE`: the build as Chrome Trace Event Format JSON (what Perfetto, chrome://tracing and clang's
// -ftime-trace read). Complete events ("ph": "X", ts and dur in microseconds since the build started), in two
// processes:
//   pid 1 "kiln"              the driver: its stages (plan, preprocess, compile, cache store, reflect, pack...) and
//                             the cache's and the remote's lookups, each kind on its own tracks
//   pid 2 "compiler workers"  one track per worker slot (tid = the slot): each job it ran, and inside the job the
//                             steps the worker timed (preprocess, front end, legalize, optimize, reflect, each back end)
// Every track's slices nest or are disjoint, never overlap in part, as the format's viewers need: the driver's stages
// that stream together (preprocess and compile) go on a second track, and a worker's steps are clamped into its job
// (a worker's answer is not trusted to stay inside it). Thread-name metadata ("ph": "M") names every track.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "driver/build_context.hpp"
#include "workers/job_runner.hpp"

namespace kiln {

class BuildTrace {
 public:
  BuildTrace(std::filesystem::path file, StageClock::time_point started) : file_(std::move(file)), started_(started) {}

  // A slice of the driver's: `kind` ("stages", "cache lookups", "remote lookups") chooses its tracks.
  void driver_slice(std::string kind, std::string name, StageClock::time_point start, StageClock::time_point end,
                    nlohmann::json args = nlohmann::json::object());
  // A job a worker process ran, named `name`, with the steps it timed (each named by its step).
  void worker_job(const JobTiming& timing, std::string name, nlohmann::json args);

  // The trace: every slice recorded, the build's stages among them (BuildContext::record_stage sends them).
  std::string to_json() const;
  // To the file, with the one output writer; a file that cannot be written is K1601 (false).
  bool write(DiagnosticSink& sink) const;

 private:
  struct Slice {
    std::string name;
    int64_t start_us = 0, end_us = 0;
    nlohmann::json args;
  };
  struct DriverSlice {
    std::string kind;
    Slice slice;
  };
  struct WorkerJob {
    unsigned slot = 0;
    Slice job;
    std::vector<Slice> steps;  // inside the job's slice, in order
  };
  int64_t us(StageClock::time_point at) const;

  std::filesystem::path file_;
  StageClock::time_point started_;
  std::vector<DriverSlice> driver_;
  std::vector<WorkerJob> jobs_;
};

}  // namespace kiln
