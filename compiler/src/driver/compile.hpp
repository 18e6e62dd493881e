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
#include "driver/compile_results.hpp"
#include "driver/messages.hpp"
#include "driver/plan.hpp"
#include "driver/result_store.hpp"
#include "driver/settings.hpp"
#include "driver/stage_sources.hpp"
#include "kiln/command_line.hpp"
#include "workers/job_runner.hpp"

namespace kiln {

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
