// SPDX-License-Identifier: Apache-2.0
// Stages 5-7 (first half): compile the binaries the cache does not have, in two halves. Each stage source's
// front end (glslang) runs once; its module is hashed, and the back end (legalize, validate, optimize, validate,
// reflect, cross-compile) runs once per distinct module, so stage sources that differ only in code their entry
// point never reaches (a fragment keyword's branch in a file the vertex stage also includes) share one. Both
// halves are cached: the back end's result under the module's key, and under the source's key an alias to it
// with the front end's warnings.
//
// Preprocessing streams into it: every stage source's Preprocess job is sent first, and each source's front end
// as soon as it is preprocessed (once per distinct source key, whichever source of that key arrives first), so no
// worker waits for the last source to be preprocessed. Nothing depends on the order jobs finish: after the
// stream, dedupe_stage_sources numbers the binaries in source order and each is settled, and its diagnostics
// collected, in that order.
//
// The scheduler knows the workers only as a JobRunner: its tests run it with an in-process fake.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "driver/build_context.hpp"
#include "driver/messages.hpp"
#include "driver/plan.hpp"
#include "driver/result_store.hpp"
#include "driver/settings.hpp"
#include "driver/stage_sources.hpp"
#include "kiln/command_line.hpp"
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
};

struct CompileServices {
  JobRunner& runner;
  ResultStore& store;          // asked for every key before it is compiled
  Preprocessor& preprocessor;  // makes the Preprocess jobs (cache misses known only through a memo included)
};

// Stages 4-6 streamed: preprocesses the sources `sources` has no key for (and the memo-known ones the store
// lacks), dedupes them into binaries (dedupe_stage_sources), and fills each binary's output (a shared, settled
// module's), or reports why it has none: preprocessing and compile errors are grouped into `messages`, worker
// deaths are internal compiler errors with a reproducer in `build.reproducers`. Every key is asked of the store
// first (driver/result_store: what it finds at once settles the key; what it answers later settles it then, while
// the other compiles go on); with --shard I/N, only the stage sources of share I (source_shares) are preprocessed,
// looked up and compiled: the others are marked `elsewhere` and have no binary. Times the stages "preprocess" (from enumerate_stage_sources to the last source preprocessed),
// "dedupe" and "compile" (from the first front end queued): the first and the last overlap.
CompileResults compile_stage_sources(BuildContext& build, const Plan& plan, const BuildSettings& settings, Shard shard,
                                     StageSources& sources, CompileServices services, const SourceLocator& locator,
                                     MessageGroups& messages);

}  // namespace kiln
