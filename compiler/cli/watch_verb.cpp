// SPDX-License-Identifier: Apache-2.0
// kiln watch: parses the arguments, blocks SIGINT and SIGTERM into a signalfd and prints what the loop
// (kiln/watch.hpp, compiler/src/watch/) reports (docs/development-loop.md).
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>

#include "cli.hpp"
#include "kiln/files.hpp"
#include "kiln/watch.hpp"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;

class WatchVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("watch", "Build a pack, then build it again whenever an input it read changes "
                                                 "(the variants in use first, with --usage; docs/development-loop.md)");
    verb->add_option("pack", pack_file_, "Pack definition (variants/*.pack.json)")->required();
    verb->add_option("-o,--output", output_, "Output directory for <name>.manifest.json and its archive")->required();
    plan_.add_to(verb);
    add_worker_and_cache_options(verb, options_, cache_dir_, no_cache_);
    std::vector<std::string> known_targets;
    for (const TargetName& target : kTargetNames) known_targets.emplace_back(target.name);
    verb->add_option("--targets", target_names_, "Override the pack's targets: " + target_name_list() + " (comma-separated)")
        ->check(CLI::IsMember(known_targets))
        ->delimiter(',');
    verb->add_option("--frontend", options_.frontend, "HLSL front end (default: glslang)")->check(CLI::IsMember(frontend_names()));
    verb->add_option("--optimize", recipe_name_, "Optimizer recipe: kiln (default) or O (as kiln build --optimize)")
        ->check(CLI::IsMember({std::string(optimizer_recipe_name(OptimizerRecipe::Kiln)),
                               std::string(optimizer_recipe_name(OptimizerRecipe::Stock))}));
    verb->add_option("--worker-timeout", timeout_s_, "Seconds one compile job may take before it is an internal error (default: " +
                                                       seconds_text(defaults::kWorkerTimeout) + ")");
    verb->add_flag("-g", options_.debug_info, "Debug information in every SPIR-V module; implies no optimization");
    verb->add_flag("--coverage", options_.coverage, "Instrument every SPIR-V module for shader code coverage (docs/coverage.md)");
    verb->add_option("--usage", usage_logs_, "The variants these usage logs asked for are built and published first each "
                                             "round, the log read again each time (repeatable; docs/usage.md)");
    verb->add_option("--usage-tag", usage_tags_, "Only the usage logs tagged KEY=VALUE count as in use (repeatable: every tag)");
    verb->add_option("--usage-margin", options_.usage_margin,
                     "With --usage, the variants at most N keyword groups away from one asked for are in use too (default: 0)");
    verb->add_option("--serve", serve_, "Serve on-demand variants to readers in development mode on 127.0.0.1:PORT (0: any "
                                        "free port), named in <pack>.endpoint beside the manifest (docs/development-loop.md)");
    verb->add_flag("--in-use-only", in_use_only_, "Build only the variants in use (--usage and what readers asked for), "
                                                  "never the full pack");
    return verb;
  }

  int run() override {
    options_.pack_file = pack_file_;
    options_.output_dir = output_;
    options_.worker_timeout = std::chrono::milliseconds(static_cast<long>(timeout_s_ * 1000));
    for (const auto& name : target_names_) options_.targets.push_back(*parse_target(name));
    if (!plan_.apply(options_)) return 1;
    options_.optimizer_recipe = *parse_optimizer_recipe(recipe_name_);
    if (options_.debug_info) options_.optimize = false;
    if (!no_cache_) options_.cache_dir = cache_dir_.empty() ? fs::path(".kiln-cache") : fs::path(cache_dir_);
    auto tags = parse_usage_tags(usage_tags_);
    if (!tags) return 1;
    options_.usage_tags = std::move(*tags);
    WatchOptions watch_options;
    if (!serve_.empty()) {
      Result<LoopbackEndpoint> endpoint = parse_loopback_endpoint(serve_);
      if (!endpoint) {
        std::cerr << "kiln: error: --serve '" << serve_ << "': " << endpoint.error().message << "\n";
        return 1;
      }
      watch_options.serve = *endpoint;
    }
    if (in_use_only_ && usage_logs_.empty()) {
      std::cerr << "kiln: error: --in-use-only needs --usage LOG: the first round builds the variants it lists\n";
      return 1;
    }
    // SIGINT and SIGTERM wait in a signalfd, read between builds: a build under way finishes (its pack is written
    // whole or not at all) and watch ends with 0. Blocked before any worker starts, so the workers (which inherit the
    // mask) are not cut off mid-job by a terminal's Ctrl-C either; they end when kiln closes their pipes.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGTERM);
    auto cannot_watch = [](const std::string& message) {
      Diagnostic diagnostic;
      diagnostic.id = DiagId::WatchUnavailable;
      diagnostic.message = message;
      std::cerr << format_diagnostic(diagnostic, colour());
      return exit_status(diagnostic_info(DiagId::WatchUnavailable).exit_class);
    };
    if (::pthread_sigmask(SIG_BLOCK, &signals, nullptr) != 0)
      return cannot_watch(std::string("cannot wait for signals: pthread_sigmask: ") + std::strerror(errno));
    Descriptor signal_fd(::signalfd(-1, &signals, SFD_NONBLOCK | SFD_CLOEXEC));
    if (signal_fd.get() < 0) return cannot_watch(std::string("cannot wait for signals: signalfd: ") + std::strerror(errno));
    watch_options.build = options_;
    watch_options.usage_logs.assign(usage_logs_.begin(), usage_logs_.end());
    watch_options.in_use_only = in_use_only_;
    WatchListener listener;
    listener.diagnostic = [](const Diagnostic& d) { std::cerr << format_diagnostic(d, colour()) << std::flush; };
    listener.status = [](const std::string& line) { std::cout << line << std::endl; };
    return watch(watch_options, signal_fd.get(), listener);
  }

 private:
  BuildOptions options_;
  PlanArguments plan_;
  std::string pack_file_, output_, cache_dir_, serve_;
  std::string recipe_name_{optimizer_recipe_name(OptimizerRecipe::Kiln)};
  std::vector<std::string> target_names_, usage_logs_, usage_tags_;
  bool no_cache_ = false, in_use_only_ = false;
  double timeout_s_ = std::chrono::duration<double>(defaults::kWorkerTimeout).count();
};

}  // namespace

std::unique_ptr<Verb> make_watch_verb() { return std::make_unique<WatchVerb>(); }

}  // namespace kiln::cli
