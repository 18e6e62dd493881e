// SPDX-License-Identifier: Apache-2.0
// Where the compile scheduler (driver/compile) finds finished results and keeps this build's: one interface over
// the tiers. The scheduler asks by key and is answered at once (the local cache) or later, while its workers run
// (the shared remote cache under it, docs/remote-cache.md); it never learns which tier answered. A slower tier's
// hit is kept in the faster ones, and what the build made goes into every tier that takes it.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "cache/cache.hpp"
#include "driver/build_context.hpp"
#include "driver/plan.hpp"
#include "driver/settings.hpp"
#include "driver/shards.hpp"
#include "driver/stage_sources.hpp"
#include "remote/remote_cache.hpp"

namespace kiln {

struct CompileResults;

// A stage source's result as a tier keeps it: the module's output with the front end's messages first, and the
// module's key (for the funnel's distinct modules and for the aliases this build keeps).
struct StoredResult {
  std::shared_ptr<const JobOutput> output;  // never null
  std::optional<Hash128> module;
};

class ResultStore {
 public:
  virtual ~ResultStore() = default;

  // A stage source's result by its key, when a tier that answers at once has it.
  virtual std::optional<StoredResult> find(const Hash128& source_key) = 0;
  // A module's back-end result by its key, when a tier that answers at once has it. `source` (whose front end made
  // the module `spirv`) keys it in the tiers that key it otherwise.
  virtual std::optional<JobOutput> find_module(const Hash128& key, const StageSource& source,
                                               const std::vector<uint32_t>& spirv) = 0;

  // Asks the slower tiers for a source find() missed. False: there is none to ask, compile it now. True: its answer
  // comes from answers() under `ticket`.
  virtual bool ask(size_t ticket, const StageSource& source) = 0;
  struct Answer {
    size_t ticket;
    std::optional<StoredResult> found;  // nothing: compile it
  };
  // The answers that arrived since the last call.
  virtual std::vector<Answer> answers() = 0;
  virtual size_t outstanding() const = 0;  // asked and not yet answered
  virtual int ready_fd() const = 0;        // readable while answers wait; -1 when there is no slower tier
  // Every question answered (this waits for them): the tiers say their problems, and the answers come that a tier
  // held back until now. With --remote-required the remote's misses are compiled only once every lookup answered,
  // and not at all when the remote failed (its error fails the build).
  virtual std::vector<Answer> finish(DiagnosticSink& sink) = 0;

  // Keeps this build's results (each module's back end, each source's alias to it, the preprocessing memos), unless
  // the input had errors: a build with errors in the user's input keeps nothing. Internal compiler errors are not
  // the input's fault: the other variants' results are kept, so the next build only retries those. Returns how many
  // entries the build found damaged in its tiers (corrupt, truncated, foreign: compiled again and rewritten).
  virtual size_t keep(BuildContext& build, const CompileResults& results, const StageSources& sources,
                      bool user_errors) = 0;
  // Then the remote's share of that (--remote-upload): what this build's front ends produced, unless the input had
  // errors. Separate, so that a shard can upload its bundle, and assemble the pack, before these entries.
  virtual void upload(BuildContext& build, const CompileResults& results, bool user_errors) = 0;
};

// The store of a build: the local cache (when there is one) and, under it, the remote (when there is one).
struct StoreTiers {
  Cache* cache = nullptr;
  bool memos = false;  // keep preprocessing memos in the local cache (not with --emit preprocessed: it wants the text)
  RemoteCache* remote = nullptr;
  bool remote_required = false;  // --remote-required
  bool upload = false;           // --remote-upload
  unsigned threads = 1;          // to encode the local cache's entries
  // The merge's: results from the shards' bundles by source key (driver/shards), found before the local cache. They
  // are not copied into the local cache: the pack they make is stamped, and the remote has their per-source entries.
  const std::map<Hash128, ShardResult>* shards = nullptr;
};

std::unique_ptr<ResultStore> make_result_store(const Plan& plan, const BuildSettings& settings, StoreTiers tiers);

}  // namespace kiln
