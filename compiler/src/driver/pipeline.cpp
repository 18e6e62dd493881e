// SPDX-License-Identifier: Apache-2.0
// The kiln pipeline, top to bottom: build_pack calls one function per stage, in order. Each lives in driver/
// (the orchestration) over its stage's folder (the work):
//   0-3 plan               driver/plan          definition/ declarations/ permutations/
//       up-to-date check   driver/settings, driver/outputs
//   4   stage sources      driver/stage_sources (preprocess in the workers, memos, dedupe)   frontend/
//   5-6 compile            driver/compile       workers/ frontend/ optimize/ cross/ cache/
//       (4-6 stream: each source is compiled as soon as it is preprocessed; see driver/compile.hpp)
//   7   layouts            driver/layouts       reflect/
//   8   pack, stamp        driver/write_pack    pack/
//       --emit, depfile    driver/emit, driver/outputs
#include <algorithm>
#include <optional>
#include <set>
#include <thread>

#include "cache/cache.hpp"
#include "common/files.hpp"
#include "driver/compile.hpp"
#include "driver/emit.hpp"
#include "driver/layouts.hpp"
#include "driver/messages.hpp"
#include "driver/outputs.hpp"
#include "driver/plan.hpp"
#include "driver/remote.hpp"
#include "driver/result_store.hpp"
#include "driver/settings.hpp"
#include "driver/shards.hpp"
#include "driver/stage_sources.hpp"
#include "driver/build_context.hpp"
#include "driver/build_trace.hpp"
#include "driver/write_pack.hpp"
#include "kiln/build.hpp"
#include "pack/pack_writer.hpp"
#include "workers/worker_pool.hpp"

namespace kiln {
namespace {

// -j: worker processes (preprocessing and compiling), and the threads of the stages that run in kiln itself
// (cache, pack).
unsigned parallelism(unsigned jobs) { return jobs ? jobs : std::max(1u, std::thread::hardware_concurrency()); }

// The compiler workers, started when the first job needs them (a build the cache serves starts none).
class OnDemandWorkers final : public JobRunner {
 public:
  OnDemandWorkers(std::filesystem::path executable, unsigned workers, WorkerLimits limits)
      : executable_(std::move(executable)), workers_(workers), limits_(std::move(limits)) {}
  void run(std::vector<CompileJob>& jobs, const std::function<void(size_t, WorkerOutcome)>& on_done,
           const ExternalWork* external) override {
    if (!pool_) pool_.emplace(executable_.empty() ? default_worker_executable() : executable_, workers_, limits_);
    pool_->run(jobs, on_done, external);
  }
  unsigned spawned() const override { return pool_ ? pool_->spawned() : 0; }
  std::vector<WorkerActivity> activity() const override { return pool_ ? pool_->activity() : std::vector<WorkerActivity>{}; }

 private:
  std::filesystem::path executable_;  // empty: default_worker_executable()
  unsigned workers_;
  WorkerLimits limits_;
  std::optional<WorkerPool> pool_;
};

// The pack in the output directory is the one these inputs make (its stamp says so): nothing to do.
bool is_up_to_date(const std::filesystem::path& output_dir, const Plan& plan, const std::string& inputs_hash) {
  auto archive = current_archive(output_dir, plan.pack.name, inputs_hash);
  if (!archive) return false;
  // A build killed after writing its archive, before or after its manifest's rename, left an orphan.
  remove_orphaned_archives(output_dir, plan.pack.name, *archive);
  return true;
}

// The summary's timeline of each worker slot, in milliseconds since the build started.
std::vector<WorkerTimeline> worker_timeline(const JobRunner& workers, const BuildContext& build) {
  auto ms = [](WorkerActivity::Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); };
  std::vector<WorkerTimeline> timeline;
  for (const WorkerActivity& a : workers.activity()) {
    WorkerTimeline t;
    t.spawned_ms = build.ms_since_start(a.spawned);
    t.last_done_ms = build.ms_since_start(a.last_done);
    t.preprocess_busy_ms = ms(a.preprocessing);
    t.compile_busy_ms = ms(a.compiling);
    t.idle_ms = t.last_done_ms - t.spawned_ms - t.preprocess_busy_ms - t.compile_busy_ms;
    if (a.compiled) {
      t.first_compile_ms = build.ms_since_start(a.first_compile);
      t.idle_before_first_compile_ms = t.first_compile_ms - t.spawned_ms - ms(a.preprocessing_before_compile);
    }
    t.jobs = a.jobs;
    timeline.push_back(t);
  }
  return timeline;
}

// The funnel, assembled here and nowhere else, from what the stages returned: the plan's counts (declared, valid,
// kept), the stage instances the enumeration saw, the distinct stage sources, compiles and modules. The pack's
// distinct binaries come with the written pack.
Funnel funnel_of(const Plan& plan, const StageSources& sources, const CompileResults& compiled) {
  Funnel funnel = plan.funnel;
  funnel.stage_instances = sources.stage_instances;
  funnel.unique_preprocessed = sources.list.size();
  funnel.unique_compiles = compiled.binaries.size();
  funnel.unique_modules = compiled.unique_modules;
  return funnel;
}

// Every input file read: the pack definition, scene profiles, usage logs and sources, and the directories where a
// new header would shadow an include (Ninja and Make see the directory change).
std::vector<std::filesystem::path> dependencies_of(const BuildOptions& options, const Plan& plan) {
  std::vector<std::filesystem::path> dependencies{std::filesystem::absolute(options.pack_file)};
  for (const auto& scene : options.scene_files) dependencies.push_back(std::filesystem::absolute(scene));
  for (const auto& log : options.usage_logs) dependencies.push_back(std::filesystem::absolute(log));
  for (const auto& [path, file] : plan.sources.files) dependencies.push_back(path);
  for (const auto& directory : plan.sources.watched) dependencies.push_back(directory);
  return dependencies;
}

// What the compile did, into the report: its counts and each worker slot's timeline.
void record_compile(const CompileResults& compiled, const JobRunner& workers, const BuildContext& build,
                    BuildReport& report) {
  report.compiled = compiled.counts.compiled;
  report.back_ends = compiled.counts.back_ends;
  report.back_end_hits = compiled.counts.back_end_hits;
  report.full_legalizations = compiled.counts.full_legalizations;
  report.cache_hits = compiled.counts.cache_hits;
  report.shard_skipped = compiled.counts.shard_skipped;
  report.workers_started = workers.spawned();
  report.worker_timeline = worker_timeline(workers, build);
}

// The remote's problems so far (once each), and its counts.
void report_remote(RemoteCache& remote, DiagnosticSink& sink, BuildReport& report) {
  remote.report_problems(sink);
  report.remote = remote.report();
}

// The shard that finished last assembles the pack as the merge would: a build of the same inputs without --shard, in
// this process, that finds every shard's bundle. What this shard already said (its share's warnings) is not repeated.
BuildReport assemble_as_last_shard(const BuildOptions& options, DiagnosticSink& sink) {
  BuildOptions merge = options;
  merge.shard_index = 0;
  merge.shard_count = 1;
  merge.trace_file.reset();  // the shard's own trace covers the assembly
  std::set<std::string> said;
  for (const Diagnostic& d : sink.diagnostics()) said.insert(format_diagnostic(d));
  DiagnosticSink assembling;
  assembling.set_listener([&](const Diagnostic& d) {
    if (!said.count(format_diagnostic(d))) sink.report(d);
  });
  return build_pack(merge, assembling);
}

// A shard's remote counts with those of the assembly it did.
void add_remote(RemoteReport& into, const RemoteReport& more) {
  into.hits += more.hits;
  into.misses += more.misses;
  into.incomplete += more.incomplete;
  into.uploads += more.uploads;
  into.blobs_uploaded += more.blobs_uploaded;
  into.bytes_down += more.bytes_down;
  into.bytes_up += more.bytes_up;
  into.errors += more.errors;
  into.shard_bundles += more.shard_bundles;
  into.shard_sources += more.shard_sources;
}

// A shard's end (--shard I/N): its share goes up first as one bundle, so that the shard that finishes last can
// assemble the pack (the merge's work, done now: a later merge fetches the finished pack); then its per-source
// entries, for the builds of other checkouts.
void finish_shard(const BuildOptions& options, BuildContext& build, const Plan& plan, const StageSources& sources,
                  const CompileResults& compiled, RemoteCache* remote, const std::optional<RemoteKey>& pack_key,
                  ResultStore& store, bool user_errors, BuildReport& report) {
  DiagnosticSink& sink = build.sink;
  const Shard shard{options.shard_index, options.shard_count};
  bool last = false;
  if (!sink.has_errors() && remote && pack_key && remote->usable()) {
    StageTimer timer(build, "shard bundle");
    last = upload_shard_bundle(*remote, *pack_key, plan, shard, sources, compiled) &&
           other_shards_finished(*remote, *pack_key, plan, shard);
  }
  std::optional<BuildReport> assembled;
  if (last) {
    StageTimer timer(build, "assemble");
    assembled = assemble_as_last_shard(options, sink);
  }
  store.upload(build, compiled, user_errors);
  if (remote) report_remote(*remote, sink, report);
  if (assembled) {
    report.shard_assembled = assembled->ok;
    report.manifest = assembled->manifest;
    report.funnel.unique_binaries = assembled->funnel.unique_binaries;
    add_remote(report.remote, assembled->remote);
  }
  report.ok = !sink.has_errors();
}

// The end of a build, whichever stage it ended at: the stage times (and --trace), and whether a compiler worker died.
BuildReport finished(BuildContext& build, BuildReport& report) {
  build.record_stage("total", build.started, StageClock::now());
  if (build.trace && !build.trace->write(build.sink)) report.ok = false;
  report.started = build.started;
  report.timings = std::move(build.timings);
  report.internal_errors = build.sink.contains(DiagId::InternalCompilerError);
  return std::move(report);
}

}  // namespace

int exit_code(const DiagnosticSink& sink, bool internal_errors) {
  return internal_errors ? exit_status(ExitClass::Internal) : exit_code(sink);
}

namespace {

PlanListing make_listing(const Plan* plan) {
  PlanListing listing;
  listing.pack = plan->pack.name;
  listing.funnel = plan->funnel;
  listing.stage_sources = count_stage_sources(*plan);
  for (size_t p = 0; p < plan->passes.size(); ++p)
    listing.pass_groups.emplace_back(plan->pack.passes[p].name, plan->passes[p].groups);
  for (const auto& [path, file] : plan->sources.files) listing.sources.emplace_back(display_path(path), file.text);
  for (const SceneProfile& scene : plan->scenes) listing.scenes.emplace_back(scene.name, scene.keywords);
  for (const PassDefinition& pass : plan->pack.passes) listing.pass_settings.push_back({pass.name, pass.bindings, pass.defines});
  for (size_t p = 0; p < plan->passes.size(); ++p) listing.pass_locations.push_back(plan->pack.passes[p].defined_at);
  listing.include_dirs = plan->pack.include_dirs;
  listing.lint_disable = plan->pack.lint_disable;
  for (size_t p = 0; p < plan->passes.size(); ++p) {
    const auto& groups = plan->passes[p].groups;
    for (const Variant& v : plan->expansions[p].variants) {
      VariantListing item;
      item.pass = plan->pack.passes[p].name;
      item.keywords = enabled_keywords(groups, v);
      for (Stage s : kAllStages)
        if (!plan->pack.passes[p].entry_points[static_cast<size_t>(s)].empty())
          item.stage_keywords.emplace_back(std::string(stage_name(s)), enabled_keywords(groups, v, s));
      listing.variants.push_back(std::move(item));
    }
  }
  return listing;
}

}  // namespace

std::optional<PlanListing> list_variants(const BuildOptions& options, DiagnosticSink& sink) {
  BuildContext build(sink);
  auto plan = make_plan(options, build);
  if (!plan) return std::nullopt;
  return make_listing(plan.get());
}

BuildReport build_pack(const BuildOptions& options, DiagnosticSink& sink) {
  BuildContext build(sink, options.output_dir / "kiln-ice", options.progress);
  std::optional<BuildTrace> trace;
  if (options.trace_file) build.trace = &trace.emplace(*options.trace_file, build.started);
  BuildReport report;
  const StageClock::time_point plan_from = StageClock::now();
  auto plan = make_plan(options, build);  // stages 0-3
  if (build.trace) build.trace->driver_slice("stages", "plan", plan_from, StageClock::now());  // the trace's parent of 0-3
  if (!plan) return finished(build, report);
  if (options.keep_plan) report.plan = make_listing(plan.get());  // lint observes the build's plan
  report.funnel = plan->funnel;
  report.strip_report = plan->strip;
  report.dependencies = dependencies_of(options, *plan);
  if (!prepare_output_directory(options.output_dir, sink)) return finished(build, report);
  auto settings = choose_settings(options, *plan, sink);
  if (!settings) return finished(build, report);
  const std::string inputs_hash = hash_inputs(*settings, *plan);
  report.manifest = manifest_path(options.output_dir, plan->pack.name);
  if (options.emit.empty() && is_up_to_date(options.output_dir, *plan, inputs_hash)) {  // --emit wants the stages' outputs
    report.up_to_date = report.ok = true;
    if (options.depfile) write_depfile(*options.depfile, report.manifest, report.dependencies, sink);
    return finished(build, report);
  }
  std::unique_ptr<RemoteCache> remote = RemoteCache::open(options.remote, sink);
  // Settings that cannot be used, when the build needs the remote (--remote-required, --remote-upload), fail it now,
  // not after compiling the whole pack.
  if (remote && !remote->usable() && (options.remote.required || options.remote.upload)) return finished(build, report);
  std::optional<RemoteKey> pack_key;
  if (remote && remote->usable() && options.emit.empty()) {
    pack_key = remote_pack_key(*remote, *settings, *plan);
    // The remote has the finished pack of these inputs (an unchanged checkout another machine built).
    const StageClock::time_point looked_from = StageClock::now();
    const bool fetched = fetch_remote_pack(*remote, *pack_key, options.output_dir, *plan, inputs_hash, sink);
    if (build.trace)
      build.trace->driver_slice("remote lookups", "remote pack lookup", looked_from, StageClock::now(), {{"found", fetched}});
    if (fetched) {
      report_remote(*remote, sink, report);
      report.ok = !sink.has_errors();
      if (options.depfile) write_depfile(*options.depfile, report.manifest, report.dependencies, sink);
      return finished(build, report);
    }
  }
  if (remote && options.remote.required && !remote->usable()) {  // --remote-required: a remote error fails the build now
    report_remote(*remote, sink, report);
    return finished(build, report);
  }
  std::optional<Cache> cache;
  if (options.cache_dir) cache.emplace(*options.cache_dir, options.cache_max_mb << 20);
  Cache* memo_cache = cache && !options.emit.count("preprocessed") ? &*cache : nullptr;  // --emit wants the text
  const WorkerLimits limits{options.worker_timeout, options.worker_memory_limit_mb, options.frontend,
                            options.interruption.fds, options.interruption.check};
  OnDemandWorkers workers(options.worker_executable, parallelism(options.jobs), limits);
  Preprocessor preprocessor(*plan, *settings, workers, build, limits);
  std::map<Hash128, ShardResult> shard_results;  // a merge's: what the shards' bundles hold
  std::unique_ptr<ResultStore> store = make_result_store(*plan, *settings,
      StoreTiers{cache ? &*cache : nullptr, memo_cache != nullptr, remote.get(), options.remote.required,
                 options.remote.upload, parallelism(options.jobs), &shard_results});
  const SourceLocator locator(*plan);
  MessageGroups messages;

  StageSources sources = enumerate_stage_sources(*plan, *settings, memo_cache);  // stage 4
  report.preprocess_memo_hits = sources.memo_hits;
  if (remote && remote->usable() && pack_key && options.shard_count <= 1) {  // a merge: one bundle per shard
    StageTimer timer(build, "shard bundles");
    shard_results = use_shard_bundles(*remote, *pack_key, *plan, sources, parallelism(options.jobs));
  }
  CompileResults compiled =  // stages 4-6, streamed: preprocess, dedupe (in source order), compile
      compile_stage_sources(build, *plan, *settings, Shard{options.shard_index, options.shard_count}, sources,
                            CompileServices{workers, *store, preprocessor}, locator, messages);
  record_compile(compiled, workers, build, report);
  report.funnel = funnel_of(*plan, sources, compiled);
  const bool user_errors = messages.has_errors();
  report.cache_rejected = store->keep(build, compiled, sources, user_errors);
  if (compiled.cancelled) {  // what finished is in the cache; its messages come again with the build that follows
    report.cancelled = true;
    return finished(build, report);
  }
  if (options.shard_count > 1) {
    messages.report(sink);
    finish_shard(options, build, *plan, sources, compiled, remote.get(), pack_key, *store, user_errors, report);
    return finished(build, report);
  }
  store->upload(build, compiled, user_errors);
  if (remote) report_remote(*remote, sink, report);
  messages.report(sink);
  bool ok = !sink.has_errors();
  if (ok) {
    auto layouts = check_pass_layouts(build, *plan, locator, sources, compiled.binaries);  // stage 7
    std::optional<WrittenVariantPack> written;
    if (layouts)  // stage 8
      written = write_variant_pack(build, *plan, *settings, sources, compiled.binaries, *layouts, inputs_hash,
                                   report.funnel, options.output_dir);
    ok = written.has_value();
    if (ok) report.funnel.unique_binaries = written->unique_binaries;
    if (ok && remote && pack_key && options.remote.upload)  // after the pack's own entries: a reader finds them first
      remote->upload_pack(*pack_key, written->archive_file, written->files.archive.parts, written->files.manifest);
    written.reset();
  }
  emit_dumps(build, *plan, sources, compiled.binaries, options.emit, options.output_dir);  // failed builds too
  if (ok && options.depfile) write_depfile(*options.depfile, report.manifest, report.dependencies, sink);
  if (remote) report_remote(*remote, sink, report);
  report.ok = ok && !sink.has_errors();
  return finished(build, report);
}

}  // namespace kiln
