// kiln build: a variant pack from a pack definition (the pipeline, compiler/src/driver/pipeline.cpp), its summary and
// --summary-json, the remote cache's options and --shard.
#include <cstdlib>
#include <iostream>

#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "kiln/command_line.hpp"
#include "kiln/files.hpp"
#include "kiln/manifest_json.hpp"
#include "progress_line.hpp"

namespace kiln::cli {
namespace {

using nlohmann::json;

void print_summary(const kiln::BuildReport& r, std::ostream& out, const std::string& shard) {
  if (!shard.empty()) {
    out << "kiln: shard " << shard << " of " << r.manifest.string() << ": compiled " << r.compiled << ", "
        << r.shard_skipped << " left to the other shards (no pack written: a build without --shard writes it)\n";
    if (r.remote.configured)
      out << "  remote cache: hits " << r.remote.hits << ", uploads " << r.remote.uploads << " (" << r.remote.blobs_uploaded
          << " blobs), " << r.remote.bytes_up << " bytes up, errors " << r.remote.errors << "\n";
    return;
  }
  const kiln::Funnel& f = r.funnel;
  const bool built = !r.up_to_date && !r.remote.pack_fetched;  // else nothing was compiled or looked up
  out << "kiln: " << (r.up_to_date ? "up to date: " : r.remote.pack_fetched ? "fetched from the remote cache: " : "wrote ")
      << r.manifest.string() << "\n";
  out << "  variants: " << (f.declared_saturated ? "more than " : "") << f.declared << " declared -> " << f.valid
      << " valid -> " << f.kept << " after stripping";
  if (built)
    out << " -> " << f.stage_instances << " stage variants -> " << f.unique_preprocessed << " unique per stage -> "
        << f.unique_compiles << " compiles -> " << f.unique_modules << " modules -> " << f.unique_binaries
        << " unique binaries";
  out << "\n";
  if (built)
    out << "  compiled " << r.compiled << " (back ends " << r.back_ends << ", full legalizations "
        << r.full_legalizations << ", cached back ends " << r.back_end_hits
        << "), cache hits " << r.cache_hits << " (not preprocessed " << r.preprocess_memo_hits << ")"
        << (r.cache_rejected ? ", rejected cache entries " + std::to_string(r.cache_rejected) : std::string())
        << ", workers " << r.workers_started << "\n";
  if (!r.up_to_date && r.remote.configured && r.remote.pack_fetched)
    out << "  remote cache: the finished pack of these inputs, " << r.remote.bytes_down << " bytes down\n";
  else if (built && r.remote.configured)
    out << "  remote cache: hits " << r.remote.hits << ", misses " << r.remote.misses
        << (r.remote.incomplete ? " (" + std::to_string(r.remote.incomplete) + " entries found in part)" : std::string())
        << ", uploads " << r.remote.uploads
        << " (" << r.remote.blobs_uploaded << " blobs"
        << (r.remote.repaired ? ", " + std::to_string(r.remote.repaired) + " damaged entries repaired" : std::string()) << "), "
        << r.remote.bytes_down << " bytes down, " << r.remote.bytes_up
        << " bytes up, errors " << r.remote.errors << (r.remote.switched_off ? " (switched off)" : "") << "\n";
  if (built && !r.strip_report.empty()) {
    out << "  strip report:\n";
    for (const kiln::StripLine& line : r.strip_report)
      out << "    " << line.pass << ": " << line.what << ": " << line.count
          << (line.reason.empty() ? "" : " (" + line.reason + ")") << "\n";
  }
  out << "  time:";
  for (size_t i = 0; i < r.timings.size(); ++i)
    out << (i ? ", " : " ") << r.timings[i].stage << " " << format_ms(r.timings[i].milliseconds);
  out << "\n";
}

// `kiln build --summary-json FILE`: what the summary says, for CI dashboards; written whether the build
// succeeded or not (README.md lists the fields; they are only ever added).
json summary_json(const kiln::BuildReport& r, const kiln::DiagnosticSink& sink, int exit_code, const kiln::BuildOptions& options) {
  // The manifest's funnel fields (one field table: src/reader/manifest.cpp), and whether the count saturated.
  json funnel = static_cast<const kiln::ManifestFunnel&>(r.funnel);
  funnel["declared_saturated"] = r.funnel.declared_saturated;
  json timings = json::array();
  for (const kiln::StageTiming& t : r.timings)
    timings.push_back({{"stage", t.stage}, {"milliseconds", t.milliseconds}, {"start_ms", t.start_ms}, {"end_ms", t.end_ms}});
  json workers = json::array();
  for (const kiln::WorkerTimeline& w : r.worker_timeline)
    workers.push_back({{"spawned_ms", w.spawned_ms}, {"first_compile_ms", w.first_compile_ms >= 0 ? json(w.first_compile_ms) : json()},
                       {"idle_before_first_compile_ms", w.first_compile_ms >= 0 ? json(w.idle_before_first_compile_ms) : json()},
                       {"last_done_ms", w.last_done_ms}, {"preprocess_busy_ms", w.preprocess_busy_ms},
                       {"compile_busy_ms", w.compile_busy_ms}, {"idle_ms", w.idle_ms}, {"jobs", w.jobs}});
  json strip = json::array();
  for (const kiln::StripLine& line : r.strip_report)
    strip.push_back({{"pass", line.pass}, {"what", line.what}, {"count", line.count}, {"reason", line.reason}});
  json out{{"ok", r.ok},
           {"exit_code", exit_code},
           {"errors", sink.error_count()},
           {"warnings", sink.warning_count()},
           {"internal_errors", r.internal_errors},
           {"up_to_date", r.up_to_date},
           {"manifest", r.ok ? json(r.manifest.string()) : json()},
           {"funnel", funnel},
           {"compiled", r.compiled},
           {"back_ends", r.back_ends},
           {"back_end_cache_hits", r.back_end_hits},
           {"full_legalizations", r.full_legalizations},
           {"cache_hits", r.cache_hits},
           {"preprocess_memo_hits", r.preprocess_memo_hits},
           {"cache_rejected", r.cache_rejected},
           {"workers", r.workers_started},
           {"remote", {{"configured", r.remote.configured}, {"switched_off", r.remote.switched_off},
                       {"pack_fetched", r.remote.pack_fetched}, {"hits", r.remote.hits}, {"misses", r.remote.misses},
                       {"incomplete", r.remote.incomplete},
                       {"uploads", r.remote.uploads}, {"blobs_uploaded", r.remote.blobs_uploaded}, {"repaired", r.remote.repaired},
                       {"bytes_down", r.remote.bytes_down}, {"bytes_up", r.remote.bytes_up}, {"errors", r.remote.errors}}},
           {"timings", timings},
           {"worker_timeline", workers},
           {"strip_report", strip}};
  if (options.shard_count > 1)
    out["shard"] = {{"index", options.shard_index}, {"count", options.shard_count}, {"left_to_other_shards", r.shard_skipped}};
  return out;
}

int run_build(kiln::BuildOptions options, bool no_cache, const std::string& cache_dir, bool quiet, const std::string& summary_file) {
  kiln::DiagnosticSink sink;
  if (!no_cache) options.cache_dir = cache_dir.empty() ? std::filesystem::path(".kiln-cache") : std::filesystem::path(cache_dir);
  std::optional<kiln::cli::ProgressLine> progress;
  if (!quiet && kiln::cli::is_interactive_terminal(2)) progress.emplace(stderr, kiln::cli::terminal_columns(2));
  if (progress) {
    sink.set_listener([&progress](const kiln::Diagnostic& d) {
      progress->print_above([&] { std::cerr << kiln::format_diagnostic(d, colour()) << std::flush; });
    });
    options.progress = [&progress](size_t done, size_t total, size_t hits) { progress->update(done, total, hits); };
  } else {
    print_diagnostics_as_they_come(sink);
  }
  kiln::BuildReport report = kiln::build_pack(options, sink);
  if (progress) progress->finish();
  const std::string shard = options.shard_count > 1 ? std::to_string(options.shard_index) + "/" + std::to_string(options.shard_count) : "";
  // With --summary-json - the JSON is standard output, and the summary for people goes to standard error.
  if (report.ok && !quiet) print_summary(report, summary_file == "-" ? std::cerr : std::cout, shard);
  int code = kiln::exit_code(sink, report.internal_errors);
  int errors = sink.error_count();
  if (summary_file == "-")
    std::cout << summary_json(report, sink, code, options).dump(2) << "\n" << std::flush;
  else if (!summary_file.empty())
    if (kiln::Result<void> written = kiln::write_file_atomic(summary_file, summary_json(report, sink, code, options).dump(2) + "\n");
        !written) {
      std::cerr << "kiln: error[K1601]: --summary-json: " << written.error().message << "\n";
      code = kiln::worse_exit_status(code, kiln::exit_status(kiln::ExitClass::Environment));
      ++errors;  // counted: "kiln: 0 error(s)" under an error was a contradiction
    }
  if (code != 0)
    std::cerr << "kiln: " << errors << " error(s)"
              << (report.internal_errors ? ", including internal compiler errors" : "") << "\n";
  return code;
}

class BuildVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("build", "Build a variant pack from a pack definition");
    verb->add_option("pack", pack_file_, "Pack definition (variants/*.pack.json)")->required();
    verb->add_option("-o,--output", output_, "Output directory for <name>.manifest.json and its archive")->required();
    plan_.add_to(verb);
    verb->add_option("-j,--jobs", options_.jobs, "Compiler worker processes (default, or 0: one per core)");
    auto* cache_opt = verb->add_option("--cache", cache_dir_, "Cache directory (default: ./.kiln-cache)");
    verb->add_flag("--no-cache", no_cache_, "Do not read or write the cache")->excludes(cache_opt);
    verb->add_option("--cache-max-mb", options_.cache_max_mb,
                      "Cache size limit: least recently used entries go first (default: " + std::to_string(kiln::defaults::kCacheMaxMb) + ")")
        ->check(CLI::PositiveNumber);
    verb->add_option("--emit", emit_, "Dump a stage: " + kiln::emit_stage_list() + " (repeatable)")
        ->check(CLI::IsMember(kiln::emit_stage_names()))
        ->delimiter(',');
    verb->add_option("--depfile", depfile_, "Write a Makefile-style depfile listing every input read");
    std::vector<std::string> known_targets;
    for (const kiln::TargetName& target : kiln::kTargetNames) known_targets.emplace_back(target.name);
    verb->add_option("--targets", target_names_, "Override the pack's targets: " + kiln::target_name_list() + " (comma-separated)")
        ->check(CLI::IsMember(known_targets))
        ->delimiter(',');
    verb->add_option("--frontend", options_.frontend, "HLSL front end (default: glslang)")
        ->check(CLI::IsMember(kiln::frontend_names()));
    verb->add_option("--optimize", recipe_name_,
                      "Optimizer recipe: kiln (default: -O without the passes kiln's legalization already did; the same "
                      "SPIR-V once IDs are compacted) or O (SPIRV-Tools' -O as spirv-opt runs it)")
        ->check(CLI::IsMember({std::string(kiln::optimizer_recipe_name(kiln::OptimizerRecipe::Kiln)),
                               std::string(kiln::optimizer_recipe_name(kiln::OptimizerRecipe::Stock))}));
    verb->add_option("--worker-timeout", timeout_s_, "Seconds one compile job may take before it is an internal error (default: " +
                                                       seconds_text(kiln::defaults::kWorkerTimeout) + ")");
    verb->add_flag("-q,--quiet", quiet_, "Print only diagnostics");
    // Usage-driven stripping (docs/usage.md).
    verb->add_option("--usage", usage_logs_, "Keep only the variants these usage logs asked for (repeatable; docs/usage.md)");
    verb->add_option("--usage-tag", usage_tags_, "Only the usage logs tagged KEY=VALUE (repeatable: every tag)");
    verb->add_option("--usage-margin", options_.usage_margin,
                     "With --usage, also keep the variants at most N keyword groups away from one asked for (default: 0)");
    verb->add_option("--summary-json", summary_file_, "Also write the build summary as JSON (funnel, cache and remote counts, "
                                                      "timings, diagnostics), whether the build succeeds or not; - for "
                                                      "standard output (the summary for people goes to standard error)");
    // The remote cache (docs/remote-cache.md). Credentials come from the environment or netrc, never from arguments.
    kiln::RemoteCacheOptions& remote = options_.remote;
    verb->add_option("--remote", remote.url, "Remote cache base URL, Bazel HTTP cache protocol (default: $KILN_REMOTE)");
    verb->add_flag("--remote-upload", remote.upload, "Upload what this build compiles (read-only otherwise)");
    verb->add_flag("--remote-required", remote.required, "Remote cache problems are errors, not warnings");
    verb->add_option("--remote-instance", remote.instance, "Path prefix under the remote URL (instance name)");
    verb->add_option("--remote-namespace", remote.key_namespace, "Mixed into every remote key: keeps caches apart on one server");
    verb->add_option("--remote-connect-timeout", remote_connect_s_,
                      "Seconds to connect to the remote cache (default: " + seconds_text(kiln::defaults::kRemoteConnectTimeout) + ")")
        ->check(CLI::PositiveNumber);
    verb->add_option("--remote-timeout", remote_timeout_s_,
                      "Seconds one remote request may take (default: " + seconds_text(kiln::defaults::kRemoteTimeout) + ")")
        ->check(CLI::PositiveNumber);
    verb->add_option("--shard", shard_text_, "I/N: compile only share I of N of the compile jobs, upload them, write no pack "
                                             "(needs --remote); auto: from Slurm's, GitLab's or a Kubernetes Indexed Job's "
                                             "environment");
    verb->add_option("--remote-transfers", remote.parallel_transfers,
                      "Remote requests in flight, one connection each (default: " + std::to_string(kiln::defaults::kRemoteParallelTransfers) + ")")
        ->check(CLI::Range(1u, 64u));
    return verb;
  }

  int run() override {
    options_.pack_file = pack_file_;
    options_.worker_timeout = std::chrono::milliseconds(static_cast<long>(timeout_s_ * 1000));
    if (!depfile_.empty()) options_.depfile = depfile_;
    options_.emit.insert(emit_.begin(), emit_.end());
    for (const auto& name : target_names_) options_.targets.push_back(*kiln::parse_target(name));
    if (!plan_.apply(options_)) return 1;
    kiln::RemoteCacheOptions& remote = options_.remote;
    options_.output_dir = output_;
    options_.optimizer_recipe = *kiln::parse_optimizer_recipe(recipe_name_);
    // The remote's URL, token and CA file may come from the environment (KILN_REMOTE_TOKEN is never printed).
    auto environment = [](const char* name) { const char* value = std::getenv(name); return value ? std::string(value) : std::string(); };
    if (remote.url.empty()) remote.url = environment("KILN_REMOTE");
    remote.bearer_token = environment("KILN_REMOTE_TOKEN");
    remote.token_file = environment("KILN_REMOTE_TOKEN_FILE");
    remote.ca_file = environment("KILN_REMOTE_CA_FILE");
    remote.connect_timeout = std::chrono::milliseconds(static_cast<long>(remote_connect_s_ * 1000));
    remote.operation_timeout = std::chrono::milliseconds(static_cast<long>(remote_timeout_s_ * 1000));
    options_.usage_logs.assign(usage_logs_.begin(), usage_logs_.end());
    auto tags = parse_usage_tags(usage_tags_);
    if (!tags) return 1;
    options_.usage_tags = std::move(*tags);
    if (!shard_text_.empty()) {
      auto process_environment = [](const char* name) { return std::getenv(name); };
      kiln::Result<kiln::Shard> shard = kiln::parse_shard_option(shard_text_, process_environment);
      if (!shard) {
        std::cerr << "kiln: error: " << shard.error().message << "\n";
        return 1;
      }
      options_.shard_index = shard->index;
      options_.shard_count = shard->count;
      if (remote.url.empty()) {
        std::cerr << "kiln: error: --shard needs a remote cache (--remote URL or KILN_REMOTE): the merge build reads the shards' work there\n";
        return 1;
      }
      remote.upload = true;  // a shard's work is for the merge
    }
    return run_build(options_, no_cache_, cache_dir_, quiet_, summary_file_);
  }

 private:
  kiln::BuildOptions options_;
  PlanArguments plan_;
  std::string pack_file_, output_, cache_dir_, depfile_, summary_file_, shard_text_;
  std::string recipe_name_{kiln::optimizer_recipe_name(kiln::OptimizerRecipe::Kiln)};
  std::vector<std::string> emit_, target_names_, usage_logs_, usage_tags_;
  bool no_cache_ = false, quiet_ = false;
  double timeout_s_ = std::chrono::duration<double>(kiln::defaults::kWorkerTimeout).count();
  double remote_connect_s_ = std::chrono::duration<double>(kiln::defaults::kRemoteConnectTimeout).count();
  double remote_timeout_s_ = std::chrono::duration<double>(kiln::defaults::kRemoteTimeout).count();
};

}  // namespace

std::unique_ptr<Verb> make_build_verb() { return std::make_unique<BuildVerb>(); }

}  // namespace kiln::cli
