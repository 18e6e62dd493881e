// SPDX-License-Identifier: Apache-2.0
// A build split over machines through the remote cache (--shard I/N; docs/remote-cache.md, "Sharding a build over
// machines"). Each shard preprocesses and compiles only its share of the stage sources (source_shares), uploads the
// per-source entries as any uploading build does, and then its whole share as one bundle (driver/shard_bundle)
// under a key of the build's inputs and its share. The merge, or the shard that finds every other shard finished,
// fetches one bundle per shard and uses them as cache hits: it preprocesses and compiles nothing that a bundle holds.
#pragma once

#include <map>
#include <memory>
#include <vector>

#include "driver/plan.hpp"
#include "driver/stage_sources.hpp"
#include "kiln/command_line.hpp"
#include "remote/remote_cache.hpp"

namespace kiln {

struct CompileResults;  // driver/compile.hpp

// The key of share `shard` of the build of these inputs (the pack-level key), and of the record of how many shards
// it was split into. Both cover the names the preprocessed text gives the files (relative to the working directory,
// in its #line directives): a shard that ran elsewhere in the checkout made other source keys.
RemoteKey remote_shard_key(const RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan, Shard shard);
RemoteKey remote_shard_count_key(const RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan);

// A shard's end: its share's results as one bundle, its record, then the shard count. False when not uploaded (the
// remote says why); the per-source entries are still there for the merge.
bool upload_shard_bundle(RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan, Shard shard,
                         const StageSources& sources, const CompileResults& compiled);

// Whether every shard but `shard` has its record on the server: this one finished last, and can assemble the pack.
bool other_shards_finished(RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan, Shard shard);

// A stage source's result from a shard's bundle, as the result store serves it.
struct ShardResult {
  Hash128 module;
  std::shared_ptr<const JobOutput> output;
  std::vector<FrontendMessage> front_messages;  // put before the output's messages
};

// The merge's start: the shard count the shards recorded, each shard's bundle, checked (decode_shard_bundle, and that
// each of its sources is the same source of this plan, in the share the bundle says). Every source a good bundle
// holds gets its key, as a preprocessing memo would give it; the results are returned by source key. A missing or
// damaged bundle (K1705, a warning) leaves its sources to the usual lookups: the remote's per-source entries, then
// the compile.
std::map<Hash128, ShardResult> use_shard_bundles(RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan,
                                                 StageSources& sources, unsigned threads);

}  // namespace kiln
