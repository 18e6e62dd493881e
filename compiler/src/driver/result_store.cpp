// SPDX-License-Identifier: Apache-2.0
#include "driver/result_store.hpp"

#include <map>

#include "common/parallel.hpp"
#include "driver/compile_results.hpp"
#include "driver/remote.hpp"
#include "driver/build_context.hpp"

namespace kiln {
namespace {

class TieredStore final : public ResultStore {
 public:
  TieredStore(const Plan& plan, const BuildSettings& settings, StoreTiers tiers)
      : plan_(plan), settings_(settings), tiers_(tiers) {
    if (tiers_.remote && tiers_.remote->usable()) lookups_.emplace(*tiers_.remote);
  }

  std::optional<StoredResult> find(const Hash128& source_key) override {
    if (tiers_.shards) {
      if (auto it = tiers_.shards->find(source_key); it != tiers_.shards->end()) {
        const ShardResult& shard = it->second;
        if (shard.front_messages.empty()) return StoredResult{shard.output, shard.module};  // shared, not copied
        JobOutput output = *shard.output;
        output.messages.insert(output.messages.begin(), shard.front_messages.begin(), shard.front_messages.end());
        return StoredResult{std::make_shared<const JobOutput>(std::move(output)), shard.module};
      }
    }
    if (!tiers_.cache) return std::nullopt;
    StoredResult found;
    auto cached = tiers_.cache->load(source_key, &found.module);
    if (!cached) return std::nullopt;
    found.output = std::make_shared<const JobOutput>(std::move(*cached));
    return found;
  }

  std::optional<JobOutput> find_module(const Hash128& key, const StageSource& source,
                                       const std::vector<uint32_t>& spirv) override {
    if (tiers_.remote && tiers_.upload)  // uploaded under this key if this build has its result
      module_remote_key_.emplace(key, remote_module_key(*tiers_.remote, settings_, plan_.pack.passes[source.pass],
                                                        source.stage, spirv));
    if (!tiers_.cache) return std::nullopt;
    return tiers_.cache->load(key);
  }

  // A local miss is asked of the remote as soon as its key is known, while the stream goes on. When the remote has
  // failed since the build started, a --remote-required build holds the miss: it is never compiled (finish).
  bool ask(size_t ticket, const StageSource& source) override {
    if (!lookups_) return false;
    if (tiers_.remote->usable()) {
      const RemoteKey key = remote_source_key(*tiers_.remote, settings_, plan_.pack.passes[source.pass], source.stage, source.text);
      source_remote_key_.emplace(*source.key, key);
      asked_key_.emplace(ticket, *source.key);
      lookups_->submit(ticket, key);
      return true;
    }
    if (!tiers_.remote_required) return false;
    held_misses_.push_back(ticket);
    return true;
  }

  // A remote hit, verified by the remote tier, goes into the local cache too. With --remote-required a miss waits
  // for every answer.
  std::vector<Answer> answers() override {
    std::vector<Answer> answers;
    if (!lookups_) return answers;
    for (auto& [ticket, fetched] : lookups_->take()) {
      if (!fetched) {
        if (tiers_.remote_required) held_misses_.push_back(ticket);
        else answers.push_back({ticket, std::nullopt});
        continue;
      }
      RemoteFetched& hit = *fetched;
      if (tiers_.cache) {
        tiers_.cache->store(hit.module, hit.module_output);
        tiers_.cache->store_alias(asked_key_.at(ticket), hit.module, hit.front_messages);
      }
      hit.module_output.messages.insert(hit.module_output.messages.begin(), hit.front_messages.begin(),
                                        hit.front_messages.end());
      answers.push_back({ticket, StoredResult{std::make_shared<const JobOutput>(std::move(hit.module_output)), hit.module}});
    }
    return answers;
  }

  size_t outstanding() const override { return lookups_ ? lookups_->outstanding() : 0; }
  int ready_fd() const override { return lookups_ ? lookups_->ready_fd() : -1; }

  std::vector<Answer> finish(DiagnosticSink& sink) override {
    std::vector<Answer> answered;
    if (!lookups_) return answered;
    while (lookups_->outstanding() > 0) {
      lookups_->wait();
      for (Answer& answer : answers()) answered.push_back(std::move(answer));
    }
    tiers_.remote->report_problems(sink);
    if (tiers_.remote->usable())
      for (size_t ticket : held_misses_) answered.push_back({ticket, std::nullopt});
    held_misses_.clear();
    return answered;
  }

  size_t keep(BuildContext& build, const CompileResults& results, const StageSources& sources, bool user_errors) override {
    return tiers_.cache ? keep_locally(build, results, sources, user_errors) : 0;
  }

  void upload(BuildContext& build, const CompileResults& results, bool user_errors) override {
    if (tiers_.remote && tiers_.upload && !user_errors) upload_entries(build, results);
    if (tiers_.remote) tiers_.remote->report_problems(build.sink);
  }

 private:
  // Entries are encoded on every core (the workers are done by now), then written as one segment file.
  size_t keep_locally(BuildContext& build, const CompileResults& results, const StageSources& sources, bool user_errors) {
    Cache& cache = *tiers_.cache;
    const std::vector<Binary>& binaries = results.binaries;
    const size_t rejected = cache.rejected_loads() + cache.unreadable_segments();
    if (rejected)
      build.sink.report(DiagId::CacheEntryRejected, SourceLocation{cache.directory().string(), 0, 0},
                        std::to_string(rejected) + " cache entr" + (rejected == 1 ? "y was" : "ies were") +
                            " corrupt, truncated or foreign: compiled again and rewritten",
                        {"nothing of them reached the outputs; if this repeats, check the disk or what else writes to the cache"});
    if (user_errors) return rejected;
    StageTimer timer(build, "cache store");
    parallel_for(results.modules.size(), tiers_.threads, [&](size_t m) {
      if (results.modules[m].fresh) cache.store(results.modules[m].key, *results.modules[m].output);
    });
    // A binary has an output only when its module's result is good (compiled now or already cached).
    parallel_for(binaries.size(), tiers_.threads, [&](size_t b) {
      if (results.front_end_ran[b] && binaries[b].output)
        cache.store_alias(binaries[b].key, *results.module_of[b], results.front_messages[b]);
    });
    if (tiers_.memos)
      parallel_for(sources.list.size(), tiers_.threads, [&](size_t i) {
        const StageSource& s = sources.list[i];
        if (!s.preprocessed || !s.ok) return;
        PreprocessMemo memo{*s.key, {}};
        for (const std::string& name : s.files_read) {
          auto hash = sources.file_hashes.find(name);
          if (hash == sources.file_hashes.end()) return;  // not a file of the snapshot: no memo
          memo.files.emplace_back(name, hash->second);
        }
        cache.store_memo(s.memo, memo);
      });
    if (Result<void> committed = cache.commit(); !committed)
      build.sink.report(DiagId::CacheUnwritable, SourceLocation{cache.directory().string(), 0, 0}, committed.error().message,
                        {"the outputs are unaffected; the next build compiles these variants again"});
    return rejected;
  }

  // What this build's front ends produced: each module's result (blobs first), then the alias of each source the
  // remote was asked for.
  void upload_entries(BuildContext& build, const CompileResults& results) {
    StageTimer timer(build, "remote upload");
    const std::vector<Binary>& binaries = results.binaries;
    std::vector<RemoteCache::ModuleUpload> uploads;
    std::map<Hash128, size_t> upload_of;
    for (const CompiledModule& m : results.modules) {
      auto key = module_remote_key_.find(m.key);
      if (m.output && key != module_remote_key_.end()) {
        upload_of.emplace(m.key, uploads.size());
        uploads.push_back({key->second, m.output.get()});
      }
    }
    std::vector<RemoteCache::AliasUpload> aliases;
    for (size_t b = 0; b < binaries.size(); ++b) {
      auto module = results.module_of[b] ? upload_of.find(*results.module_of[b]) : upload_of.end();
      auto key = source_remote_key_.find(binaries[b].key);
      if (results.front_end_ran[b] && binaries[b].output && key != source_remote_key_.end() && module != upload_of.end())
        aliases.push_back({key->second, module->second, *results.module_of[b], &results.front_messages[b]});
    }
    tiers_.remote->upload(uploads, aliases);
  }

  const Plan& plan_;
  const BuildSettings& settings_;
  StoreTiers tiers_;
  std::optional<RemoteLookups> lookups_;          // when the remote is usable at the start
  std::map<size_t, Hash128> asked_key_;           // ticket -> the source key asked of the remote
  std::vector<size_t> held_misses_;               // --remote-required: misses, compiled once every lookup answered
  std::map<Hash128, RemoteKey> source_remote_key_;  // source key -> its remote key, for the sources asked
  std::map<Hash128, RemoteKey> module_remote_key_;  // module key -> its remote key, with --remote-upload
};

}  // namespace

std::unique_ptr<ResultStore> make_result_store(const Plan& plan, const BuildSettings& settings, StoreTiers tiers) {
  return std::make_unique<TieredStore>(plan, settings, tiers);
}

}  // namespace kiln
