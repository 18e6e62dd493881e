// SPDX-License-Identifier: Apache-2.0
#include "driver/shards.hpp"

#include <algorithm>
#include <new>

#include "common/files.hpp"
#include "driver/compile_results.hpp"
#include "driver/shard_bundle.hpp"

namespace kiln {
namespace {

RemoteKeyHasher& add_shard_inputs(RemoteKeyHasher& key, const RemoteKey& pack_key, const Plan& plan) {
  key.add(pack_key.hex());
  for (const auto& [path, file] : plan.sources.files) key.add(display_path(path));
  return key;
}

}  // namespace

RemoteKey remote_shard_key(const RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan, Shard shard) {
  RemoteKeyHasher key;
  remote.start_key(key, "shard");
  return add_shard_inputs(key, pack_key, plan).add(uint64_t{shard.index}).add(uint64_t{shard.count}).finish();
}

RemoteKey remote_shard_count_key(const RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan) {
  RemoteKeyHasher key;
  remote.start_key(key, "shard count");
  return add_shard_inputs(key, pack_key, plan).finish();
}

bool upload_shard_bundle(RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan, Shard shard,
                         const StageSources& sources, const CompileResults& compiled) {
  ShardBundle bundle;
  bundle.index = shard.index;
  bundle.count = shard.count;
  bundle.source_count = sources.list.size();
  std::map<const JobOutput*, uint32_t> output_index;  // binaries of one module share its output
  std::vector<const JobOutput*> outputs;
  for (size_t i = 0; i < sources.list.size(); ++i) {
    const StageSource& s = sources.list[i];
    if (s.elsewhere) continue;
    if (s.binary < 0 || !compiled.binaries[static_cast<size_t>(s.binary)].output) return false;  // not a good share
    const size_t b = static_cast<size_t>(s.binary);
    const JobOutput* output = compiled.binaries[b].output.get();
    auto [it, inserted] = output_index.emplace(output, static_cast<uint32_t>(outputs.size()));
    if (inserted) outputs.push_back(output);
    ShardBundle::Source& entry = bundle.sources.emplace_back();
    entry.source = static_cast<uint32_t>(i);
    entry.identity = source_identity(s);
    entry.key = *s.key;
    entry.module = compiled.module_of[b].value_or(compiled.binaries[b].key);
    entry.output = it->second;
    if (compiled.front_end_ran[b]) entry.messages = compiled.front_messages[b];
  }
  return remote.upload_shard(remote_shard_key(remote, pack_key, plan, shard), encode_shard_bundle(bundle, outputs)) &&
         remote.upload_shard_count(remote_shard_count_key(remote, pack_key, plan), shard.count);
}

bool other_shards_finished(RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan, Shard shard) {
  std::vector<RemoteKey> others;
  for (unsigned i = 0; i < shard.count; ++i)
    if (i != shard.index) others.push_back(remote_shard_key(remote, pack_key, plan, Shard{i, shard.count}));
  const std::vector<bool> there = remote.have_records(others);
  return std::all_of(there.begin(), there.end(), [](bool b) { return b; });
}

std::map<Hash128, ShardResult> use_shard_bundles(RemoteCache& remote, const RemoteKey& pack_key, const Plan& plan,
                                                 StageSources& sources, unsigned threads) {
  std::map<Hash128, ShardResult> results;
  const std::optional<uint32_t> count = remote.fetch_shard_count(remote_shard_count_key(remote, pack_key, plan));
  if (!count) return results;
  // Shares past the number of stage sources are empty: their bundles hold nothing to fetch (and a forged count of
  // 100,000 costs no more requests than the plan has sources).
  const uint32_t holding = static_cast<uint32_t>(std::min<size_t>(*count, sources.list.size()));
  std::vector<RemoteKey> keys;
  for (uint32_t i = 0; i < holding; ++i) keys.push_back(remote_shard_key(remote, pack_key, plan, Shard{i, *count}));
  const std::vector<uint32_t> shares = source_shares(sources, *count);
  size_t used = 0, used_bundles = 0;
  // One bundle at a time as the batches arrive: decoded, checked, its results kept, its bytes freed.
  remote.fetch_shards(keys, [&](size_t i, std::string&& bytes) {
    std::string problem;
    try {
      Result<ShardBundle> decoded = decode_shard_bundle(bytes, threads);
      std::string().swap(bytes);
      problem = decoded ? "" : decoded.error().message;
      if (decoded && (decoded->index != i || decoded->count != *count || decoded->source_count != sources.list.size()))
        problem = "a shard bundle is of another share or another plan";
      // Every source of the share, once, the same source as this plan's: else the bundle is of something else.
      std::vector<char> seen(sources.list.size(), 0);
      size_t share_size = 0;
      for (uint32_t share : shares) share_size += share == i;
      if (problem.empty()) {
        for (const ShardBundle::Source& entry : decoded->sources)
          if (shares[entry.source] != i || seen[entry.source]++ || source_identity(sources.list[entry.source]) != entry.identity)
            problem = "a shard bundle's sources are not its share of this plan";
        if (problem.empty() && decoded->sources.size() != share_size) problem = "a shard bundle does not hold its whole share";
      }
      if (problem.empty()) {
        ++used_bundles;
        std::vector<std::shared_ptr<const JobOutput>> outputs;
        for (JobOutput& output : decoded->outputs) outputs.push_back(std::make_shared<const JobOutput>(std::move(output)));
        for (ShardBundle::Source& entry : decoded->sources) {
          StageSource& s = sources.list[entry.source];
          if (s.key && *s.key != entry.key) continue;  // a local memo, checked against the files, says otherwise
          s.ok = true;
          s.key = entry.key;
          results.emplace(entry.key, ShardResult{entry.module, outputs[entry.output], std::move(entry.messages)});
          ++used;
        }
      }
    } catch (const std::bad_alloc&) {
      // A bundle this process cannot decode in memory (a hostile remote's, or a machine short of memory): its share
      // is looked up source by source. Results already kept are whole; the sources not reached are compiled.
      problem = "a shard bundle was larger than this process could decode in memory";
    }
    if (!problem.empty())
      remote.entry_rejected(problem, "the bundle of shard " + std::to_string(i) + "/" + std::to_string(*count) + ", ac/" + keys[i].hex());
  });
  remote.count_shard_bundles(used_bundles, used);
  return results;
}

}  // namespace kiln
