// SPDX-License-Identifier: Apache-2.0
// kiln build: a variant pack from a pack definition (the pipeline, compiler/src/driver/pipeline.cpp), its summary and
// --summary-json (kiln/build_summary.hpp), --trace (driver/build_trace.hpp), the remote cache's options and --shard.
#include <cstdlib>
#include <iostream>

#include "cli.hpp"
#include "kiln/build_summary.hpp"
#include "kiln/command_line.hpp"
#include "kiln/files.hpp"
#include "progress_line.hpp"

namespace kiln::cli {
namespace {

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
  // With --summary-json - or --trace - the JSON is standard output, and the summary for people goes to standard error.
  const bool json_on_stdout = summary_file == "-" || options.trace_file == std::filesystem::path("/dev/stdout");
  if (report.ok && !quiet) (json_on_stdout ? std::cerr : std::cout) << kiln::build_summary_text(report, options);
  int code = kiln::exit_code(sink, report.internal_errors);
  int errors = sink.error_count();
  if (summary_file == "-")
    std::cout << kiln::build_summary_json(report, sink, code, options) << std::flush;
  else if (!summary_file.empty())
    if (kiln::Result<void> written = kiln::write_output_file(summary_file, kiln::build_summary_json(report, sink, code, options));
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
    add_worker_and_cache_options(verb, options_, cache_dir_, no_cache_);
    verb->add_option("--emit", emit_, "Dump a stage: " + kiln::emit_stage_list() + " (repeatable)")
        ->check(CLI::IsMember(kiln::emit_stage_names()))
        ->delimiter(',');
    verb->add_option("--depfile", depfile_, "Write a Makefile-style depfile listing every input read (-: standard output)");
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
    verb->add_flag("-g", options_.debug_info,
                   "Debug information in every SPIR-V module (source, lines, names, as kiln compile -g writes them); "
                   "implies no optimization");
    verb->add_flag("--coverage", options_.coverage,
                   "Instrument every SPIR-V module for shader code coverage (docs/coverage.md): each block records into a "
                   "storage buffer that it ran, and keeps its HLSL lines; implies debug information and no optimization");
    // Usage-driven stripping (docs/usage.md).
    verb->add_option("--usage", usage_logs_, "Keep only the variants these usage logs asked for (repeatable; docs/usage.md)");
    verb->add_option("--usage-tag", usage_tags_, "Only the usage logs tagged KEY=VALUE (repeatable: every tag)");
    verb->add_option("--usage-margin", options_.usage_margin,
                     "With --usage, also keep the variants at most N keyword groups away from one asked for (default: 0)");
    verb->add_option("--summary-json", summary_file_, "Also write the build summary as JSON (funnel, cache and remote counts, "
                                                      "timings, diagnostics), whether the build succeeds or not; - for "
                                                      "standard output (the summary for people goes to standard error)");
    verb->add_option("--trace", trace_file_, "Also write a trace of the build (Chrome Trace Event Format JSON, for Perfetto "
                                             "or chrome://tracing): its stages, each worker's jobs and their steps, the "
                                             "cache and remote lookups (docs/build-trace.md)");
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
    verb->add_option("--shard", shard_text_, "I/N: build only share I of N of the stage sources and upload it as one "
                                             "bundle; the shard that finds every other shard's bundle writes the pack "
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
    // `-`: standard output, as for --summary-json (the writer writes a descriptor's link in place).
    if (!depfile_.empty()) options_.depfile = depfile_ == "-" ? "/dev/stdout" : depfile_;
    if (!trace_file_.empty()) options_.trace_file = trace_file_ == "-" ? "/dev/stdout" : trace_file_;
    if (trace_file_ == "-" && summary_file_ == "-") {
      std::cerr << "kiln: error: --trace - and --summary-json - would both write standard output: give one a file\n";
      return 1;
    }
    options_.emit.insert(emit_.begin(), emit_.end());
    for (const auto& name : target_names_) options_.targets.push_back(*kiln::parse_target(name));
    if (!plan_.apply(options_)) return 1;
    kiln::RemoteCacheOptions& remote = options_.remote;
    options_.output_dir = output_;
    options_.optimizer_recipe = *kiln::parse_optimizer_recipe(recipe_name_);
    if (options_.debug_info) options_.optimize = false;  // as kiln compile -g: the source's code, not the optimizer's
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
  std::string pack_file_, output_, cache_dir_, depfile_, summary_file_, shard_text_, trace_file_;
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
