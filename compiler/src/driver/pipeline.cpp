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
#include "driver/stage_sources.hpp"
#include "driver/stage_timer.hpp"
#include "driver/write_pack.hpp"
#include "kiln/build.hpp"
#include "pack/pack_writer.hpp"
#include "workers/worker_pool.hpp"

namespace kiln {
namespace {

// -j: worker processes (preprocessing and compiling), and the threads of the stages that run in kiln itself
// (cache, pack).
unsigned parallelism(const BuildOptions& options) {
  return options.jobs ? options.jobs : std::max(1u, std::thread::hardware_concurrency());
}

// The compiler workers, started when the first job needs them (a build the cache serves starts none).
class OnDemandWorkers final : public JobRunner {
 public:
  explicit OnDemandWorkers(const BuildOptions& options) : options_(options) {}
  void run(std::vector<CompileJob>& jobs, const std::function<void(size_t, WorkerOutcome)>& on_done,
           const ExternalWork* external) override {
    if (!pool_) {
      std::filesystem::path exe =
          options_.worker_executable.empty() ? default_worker_executable() : options_.worker_executable;
      pool_.emplace(exe, parallelism(options_),
                    WorkerLimits{options_.worker_timeout, options_.worker_memory_limit_mb, options_.frontend});
    }
    pool_->run(jobs, on_done, external);
  }
  unsigned spawned() const override { return pool_ ? pool_->spawned() : 0; }
  std::vector<WorkerActivity> activity() const override { return pool_ ? pool_->activity() : std::vector<WorkerActivity>{}; }

 private:
  const BuildOptions& options_;
  std::optional<WorkerPool> pool_;
};

// The pack in the output directory is the one these inputs make (its stamp says so): nothing to do.
bool is_up_to_date(const BuildOptions& options, const Plan& plan, const std::string& inputs_hash, DiagnosticSink& sink,
                   BuildReport& report) {
  if (!options.emit.empty()) return false;  // --emit wants the stages' outputs
  auto archive = current_archive(options.output_dir, plan.pack.name, inputs_hash);
  if (!archive) return false;
  // A build killed after writing its archive, before or after its manifest's rename, left an orphan.
  remove_orphaned_archives(options.output_dir, plan.pack.name, *archive);
  report.up_to_date = report.ok = true;
  if (options.depfile) write_depfile(*options.depfile, report.manifest, report.dependencies, sink);
  return true;
}

// The remote had the finished pack of these inputs (an unchanged checkout another machine built).
bool fetched_from_remote(RemoteCache& remote, const RemoteKey& pack_key, const BuildOptions& options, const Plan& plan,
                         const std::string& inputs_hash, DiagnosticSink& sink, BuildReport& report) {
  if (!fetch_remote_pack(remote, pack_key, options, plan, inputs_hash, sink)) return false;
  report_remote(remote, sink, report);
  report.ok = !sink.has_errors();
  if (options.depfile) write_depfile(*options.depfile, report.manifest, report.dependencies, sink);
  return true;
}

// The summary's timeline of each worker slot, in milliseconds since the build started.
void record_worker_timeline(const JobRunner& workers, BuildReport& report) {
  auto ms = [](WorkerActivity::Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); };
  for (const WorkerActivity& a : workers.activity()) {
    WorkerTimeline t;
    t.spawned_ms = ms_since_start(report, a.spawned);
    t.last_done_ms = ms_since_start(report, a.last_done);
    t.preprocess_busy_ms = ms(a.preprocessing);
    t.compile_busy_ms = ms(a.compiling);
    t.idle_ms = t.last_done_ms - t.spawned_ms - t.preprocess_busy_ms - t.compile_busy_ms;
    if (a.compiled) {
      t.first_compile_ms = ms_since_start(report, a.first_compile);
      t.idle_before_first_compile_ms = t.first_compile_ms - t.spawned_ms - ms(a.preprocessing_before_compile);
    }
    t.jobs = a.jobs;
    report.worker_timeline.push_back(t);
  }
}

// The funnel, assembled here and nowhere else, from what the stages returned: the plan's counts (declared, valid,
// kept), the stage instances the enumeration saw, the distinct stage sources, compiles and modules. The pack's
// distinct binaries come with the written pack.
Funnel funnel_of(const Plan& plan, const StageSources& sources, const std::vector<Binary>& binaries,
                 const CompileResults& compiled) {
  Funnel funnel = plan.funnel;
  funnel.stage_instances = sources.stage_instances;
  funnel.unique_preprocessed = sources.list.size();
  funnel.unique_compiles = binaries.size();
  funnel.unique_modules = compiled.unique_modules;
  return funnel;
}

void record_dependencies(const BuildOptions& options, const Plan& plan, BuildReport& report) {
  report.funnel = plan.funnel;
  report.strip_report = plan.strip;
  report.dependencies.push_back(std::filesystem::absolute(options.pack_file));
  for (const auto& scene : options.scene_files) report.dependencies.push_back(std::filesystem::absolute(scene));
  for (const auto& log : options.usage_logs) report.dependencies.push_back(std::filesystem::absolute(log));
  for (const auto& [path, file] : plan.sources.files) report.dependencies.push_back(path);
  // A new header in one of these directories would shadow an include: Ninja and Make see the directory change.
  for (const auto& directory : plan.sources.watched) report.dependencies.push_back(directory);
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
  for (size_t p = 0; p < plan->passes.size(); ++p)
    listing.pass_groups.emplace_back(plan->pack.passes[p].name, plan->passes[p].groups);
  for (const auto& [path, file] : plan->sources.files) listing.sources.emplace_back(display_path(path), file.text);
  for (const SceneProfile& scene : plan->scenes) listing.scenes.emplace_back(scene.name, scene.keywords);
  for (const PassDefinition& pass : plan->pack.passes) listing.pass_settings.push_back({pass.name, pass.bindings, pass.defines});
  for (size_t p = 0; p < plan->passes.size(); ++p) listing.pass_locations.push_back(plan->pack.passes[p].defined_at);
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
  BuildReport report;
  auto plan = make_plan(options, sink, report);
  if (!plan) return std::nullopt;
  return make_listing(plan.get());
}

BuildReport build_pack(const BuildOptions& options, DiagnosticSink& sink) {
  BuildReport report;
  std::optional<StageTimer> total(std::in_place, report, "total");
  auto finish = [&] {
    total.reset();
    return report;
  };

  auto plan = make_plan(options, sink, report);  // stages 0-3
  if (!plan) return finish();
  if (options.keep_plan) report.plan = make_listing(plan.get());  // lint observes the build's plan
  record_dependencies(options, *plan, report);
  if (!prepare_output_directory(options.output_dir, sink)) return finish();
  auto settings = choose_settings(options, *plan, sink);
  if (!settings) return finish();
  const std::string inputs_hash = hash_inputs(*settings, *plan, options);
  report.manifest = manifest_path(options.output_dir, plan->pack.name);
  if (is_up_to_date(options, *plan, inputs_hash, sink, report)) return finish();
  std::unique_ptr<RemoteCache> remote = RemoteCache::open(options.remote, sink);
  // Settings that cannot be used, when the build needs the remote (--remote-required, --remote-upload), fail it now,
  // not after compiling the whole pack.
  if (remote && !remote->usable() && (options.remote.required || options.remote.upload)) return finish();
  std::optional<RemoteKey> pack_key;
  if (remote && remote->usable() && options.emit.empty()) {
    pack_key = remote_pack_key(*remote, *settings, *plan, options);
    if (fetched_from_remote(*remote, *pack_key, options, *plan, inputs_hash, sink, report)) return finish();
  }
  if (remote && options.remote.required && !remote->usable()) {  // --remote-required: a remote error fails the build now
    report_remote(*remote, sink, report);
    return finish();
  }
  std::optional<Cache> cache;
  if (options.cache_dir) cache.emplace(*options.cache_dir, options.cache_max_mb << 20);
  Cache* memo_cache = cache && !options.emit.count("preprocessed") ? &*cache : nullptr;  // --emit wants the text
  OnDemandWorkers workers(options);
  Preprocessor preprocessor(*plan, *settings, workers, options);
  const SourceLocator locator(*plan);
  MessageGroups messages;

  std::unique_ptr<ResultStore> store = make_result_store(
      *plan, *settings,
      StoreTiers{cache ? &*cache : nullptr, memo_cache != nullptr, remote.get(), options.remote.required,
                 options.remote.upload, parallelism(options)});

  StageSources sources = enumerate_stage_sources(*plan, *settings, memo_cache, report);  // stage 4
  std::vector<Binary> binaries;  // stages 4-6, streamed: preprocess, dedupe (in source order), compile
  CompileResults compiled = compile_stage_sources(*plan, options, *settings, sources, binaries,
                                                  CompileServices{workers, *store, preprocessor}, locator, messages,
                                                  sink, report);
  record_worker_timeline(workers, report);
  report.funnel = funnel_of(*plan, sources, binaries, compiled);
  store->keep(compiled, sources, binaries, messages.has_errors(), sink, report);
  messages.report(sink);
  bool ok = !sink.has_errors();
  if (ok && options.shard_count > 1) {  // a shard's share is in the caches (and uploaded); the merge writes the pack
    report.ok = true;
    return finish();
  }
  if (ok) {
    auto layouts = check_pass_layouts(*plan, locator, sources, binaries, sink, report);  // stage 7
    std::optional<WrittenVariantPack> written;
    if (layouts)
      written = write_variant_pack(*plan, options, *settings, sources, binaries, *layouts, inputs_hash, report.funnel, sink, report);
    ok = written.has_value();
    if (ok) report.funnel.unique_binaries = written->unique_binaries;
    if (ok && remote && pack_key && options.remote.upload)  // after the pack's own entries: a reader finds them first
      remote->upload_pack(*pack_key, options.output_dir, plan->pack.name, written->archive_file);
  }
  emit_dumps(*plan, sources, binaries, options, sink, report);  // failed builds too
  if (ok && options.depfile) write_depfile(*options.depfile, report.manifest, report.dependencies, sink);
  if (remote) report_remote(*remote, sink, report);
  report.ok = ok && !sink.has_errors();
  return finish();
}

}  // namespace kiln
