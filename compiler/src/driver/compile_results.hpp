// SPDX-License-Identifier: Apache-2.0
// What the compile stage (driver/compile.hpp) made: its modules, binaries and counts. Apart from the scheduler, so
// that the stages that keep or ship the results (driver/result_store, driver/shards) read them without including
// the compile stage, which uses them.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <vector>

#include "common/compile_result.hpp"
#include "common/hash.hpp"
#include "driver/stage_sources.hpp"
#include "workers/job_runner.hpp"

namespace kiln {

// A distinct front-end module and its back end's result.
struct CompiledModule {
  Hash128 key;
  bool settled = false;                     // its back end has finished, or the cache had it
  std::shared_ptr<const JobOutput> output;  // when settled and good
  WorkerOutcome failure;                    // when settled and not good
  std::vector<uint32_t> failed_input;       // when its back end's worker died: the module it was given (reproducer)
  bool fresh = false;                       // compiled in this build: cached once the build is known good
  std::vector<size_t> waiting;              // source keys whose front end produced it, before it settled
};

// What a compile did, for the summary.
struct CompileCounts {
  size_t compiled = 0;            // stage sources compiled (front ends run)
  size_t back_ends = 0;           // back ends run: one per distinct front-end module the store did not have
  size_t back_end_hits = 0;       // front-end modules whose back end the store had
  size_t full_legalizations = 0;  // back ends run whose module needed SPIRV-Tools' full legalization recipe
  size_t cache_hits = 0;          // stage sources the store had whole (nothing run)
  size_t shard_skipped = 0;       // stage sources left to the other shards (--shard), not preprocessed here
};

// What a compile made: the binaries (distinct stage sources, in source order, each with its output when it has
// one), the modules (the fresh ones are kept by the result store), and each binary's module and front-end warnings.
struct CompileResults {
  std::vector<Binary> binaries;
  std::vector<CompiledModule> modules;
  std::vector<std::optional<Hash128>> module_of;              // per binary: its module's key, when known
  std::vector<std::vector<FrontendMessage>> front_messages;  // per binary, when its front end ran now
  std::vector<bool> front_end_ran;                            // per binary
  size_t unique_modules = 0;  // distinct front-end modules among the built binaries (the funnel's)
  CompileCounts counts;
  // The build was interrupted (BuildOptions::interruption): the jobs not run left their sources, keys or modules
  // without a result and without a message. What finished is kept (the cache); no pack can be written.
  bool cancelled = false;
};

}  // namespace kiln
