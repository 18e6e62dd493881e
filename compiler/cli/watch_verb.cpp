// kiln watch: builds a pack, then watches every input the build read and builds again on each change, the variants
// in use first (--usage: published as soon as they are done), then the full pack (docs/development-loop.md).
// Event-driven and bounded (STYLE.md rule 19): one inotify descriptor on the directories that hold the inputs and a
// signalfd for SIGINT and SIGTERM, both in one poll(); nothing sleeps, and a round holds nothing the next one keeps.
#include <poll.h>
#include <signal.h>
#include <sys/inotify.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iomanip>
#include <iostream>
#include <set>
#include <sstream>

#include "cli.hpp"
#include "kiln/files.hpp"

namespace kiln::cli {
namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

// At most this many changed names are listed in a status line (a checkout touching 500 files is "and 495 more").
constexpr size_t kListedChanges = 8;

class Descriptor {
 public:
  explicit Descriptor(int fd = -1) : fd_(fd) {}
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }

 private:
  int fd_;
};

bool is_below(const fs::path& path, const fs::path& root) {
  auto p = path.begin();
  for (auto r = root.begin(); r != root.end(); ++r, ++p)
    if (!r->empty() && (p == path.end() || *p != *r)) return false;
  return true;
}

fs::path canonical_or_absolute(const fs::path& path) {
  std::error_code ec;
  fs::path canonical = fs::weakly_canonical(fs::absolute(path, ec), ec);
  return ec ? fs::absolute(path) : canonical;
}

// What changed since the last round: the first few names, and how many more. A name that is no input (a new file
// in a directory where it could shadow an include) counts only if it is still there once the save is over: editors
// and sed write temporary files beside the one they save and rename them over it.
struct Changes {
  std::set<std::string> names;
  size_t more = 0;
  std::set<fs::path> maybe;  // new names that are no input yet: counted by settle() if they are still there
  Clock::time_point first_seen{};

  bool empty() const { return names.empty() && more == 0; }
  bool pending() const { return !empty() || !maybe.empty(); }
  void add(const std::string& name) {
    if (!pending()) first_seen = Clock::now();
    if (names.count(name) || names.size() < kListedChanges) names.insert(name);
    else ++more;
  }
  void add_if_it_stays(const fs::path& path) {
    if (!pending()) first_seen = Clock::now();
    if (maybe.size() < kListedChanges * 8) maybe.insert(path);
    else add(display_path(path));  // a flood of new names is a change in any case
  }
  void settle() {
    for (const fs::path& path : maybe) {
      std::error_code ec;
      if (fs::exists(fs::symlink_status(path, ec))) add(display_path(path));
    }
    maybe.clear();
  }
  std::string text() const {
    std::string listed;
    for (const std::string& name : names) listed += (listed.empty() ? "" : ", ") + name;
    if (more) listed += ", and " + std::to_string(more) + " more";
    return listed + " changed";
  }
};

std::string counted(size_t count, const char* one, const char* more) {
  return std::to_string(count) + " " + (count == 1 ? one : more);
}

// The directories that hold the last build's inputs, one inotify watch each (editors save by rename, so a file's
// own watch would follow the old file away). In each, the names that are inputs matter; in a directory where a new
// file would shadow an include, any new name does; after a build that failed (its inputs unknown or incomplete: a
// missing include, an #include the plan never reached), any new or written name in any of them does.
class InputWatch {
 public:
  explicit InputWatch(std::vector<fs::path> outputs) {
    for (fs::path& output : outputs)
      if (!output.empty()) outputs_.push_back(std::move(output));
  }
  bool open() {
    fd_ = std::make_unique<Descriptor>(::inotify_init1(IN_NONBLOCK | IN_CLOEXEC));
    return fd_->get() >= 0;
  }
  int fd() const { return fd_->get(); }

  // `inputs`: files and directories, as BuildReport::dependencies lists them.
  void watch(const std::vector<fs::path>& inputs, bool any_change) {
    any_change_ = any_change;
    std::map<fs::path, Interest> interest;
    for (const fs::path& input : inputs) {
      const fs::path path = canonical_or_absolute(input);
      std::error_code ec;
      if (fs::is_directory(path, ec)) interest[path].new_names = true;
      else interest[path.parent_path()].names.insert(path.filename().string());
    }
    for (auto it = watches_.begin(); it != watches_.end();) {
      if (interest.count(it->first)) {
        ++it;
        continue;
      }
      ::inotify_rm_watch(fd(), it->second);
      directories_.erase(it->second);
      it = watches_.erase(it);
    }
    constexpr uint32_t kEvents = IN_CLOSE_WRITE | IN_MOVED_TO | IN_MOVED_FROM | IN_CREATE | IN_DELETE | IN_ATTRIB |
                                 IN_DELETE_SELF | IN_MOVE_SELF | IN_ONLYDIR;
    for (const auto& [directory, wanted] : interest) {
      if (watches_.count(directory)) continue;
      // A directory that is not there now (removed with its files) is tried again after the next round.
      const int wd = ::inotify_add_watch(fd(), directory.c_str(), kEvents);
      if (wd < 0) continue;
      watches_[directory] = wd;
      directories_[wd] = directory;
    }
    interest_ = std::move(interest);
  }

  // Reads every event queued (the descriptor does not block); the inputs they changed go into `changes`.
  void read(Changes& changes) {
    alignas(inotify_event) char buffer[16384];
    for (;;) {
      const ssize_t n = ::read(fd(), buffer, sizeof buffer);
      if (n <= 0) return;  // EAGAIN: nothing more queued (EINTR cannot come: the signals are blocked)
      for (ssize_t at = 0; at < n;) {
        const auto* event = reinterpret_cast<const inotify_event*>(buffer + at);
        at += static_cast<ssize_t>(sizeof(inotify_event) + event->len);
        take(*event, changes);
      }
    }
  }

  size_t files() const {
    size_t count = 0;
    for (const auto& [directory, wanted] : interest_) count += wanted.names.size();
    return count;
  }
  size_t directories() const { return watches_.size(); }

 private:
  struct Interest {
    std::set<std::string> names;  // the inputs in this directory
    bool new_names = false;       // a new file here would shadow an include
  };

  void take(const inotify_event& event, Changes& changes) {
    if (event.mask & IN_Q_OVERFLOW) {
      changes.add("(more changes than the kernel queued)");
      return;
    }
    auto found = directories_.find(event.wd);
    if (found == directories_.end()) return;
    const fs::path directory = found->second;
    if (event.mask & IN_IGNORED) {  // the directory went, and its watch with it: added again after the next round
      watches_.erase(directory);
      directories_.erase(found);
      changes.add(display_path(directory));
      return;
    }
    if (event.mask & (IN_DELETE_SELF | IN_MOVE_SELF)) {
      changes.add(display_path(directory));
      return;
    }
    if (event.len == 0) return;
    const std::string name = event.name;
    const fs::path path = directory / name;
    // What the builds write (the pack, the cache) never starts a round, even inside a watched directory.
    for (const fs::path& output : outputs_)
      if (is_below(path, output)) return;
    const auto interest = interest_.find(directory);
    if (interest == interest_.end()) return;
    const Interest& wanted = interest->second;
    if (wanted.names.count(name)) {
      changes.add(display_path(path));
      return;
    }
    // Any other name matters only where it could be read next (not a removed one, which was no input, and not a
    // hidden one: editors' swap files, kiln's own temporary outputs), and only if it stays.
    if (name[0] == '.' || (event.mask & (IN_DELETE | IN_MOVED_FROM))) return;
    if (any_change_ || (wanted.new_names && (event.mask & (IN_CREATE | IN_MOVED_TO)))) changes.add_if_it_stays(path);
  }

  std::vector<fs::path> outputs_;
  std::unique_ptr<Descriptor> fd_;
  std::map<fs::path, Interest> interest_;
  std::map<fs::path, int> watches_;     // directory -> watch descriptor
  std::map<int, fs::path> directories_;  // watch descriptor -> directory
  bool any_change_ = true;
};

// One build of a round: the in-use pack or the full one.
struct Phase {
  enum class Outcome { NotRun, Built, UpToDate, Failed, Restarted, Stopped, NoUsageLog } outcome = Outcome::NotRun;
  uint64_t variants = 0;
  size_t compiled = 0, cache_hits = 0;
  int errors = 0;
  double seconds = 0;  // from the first change of the round (or the start) to the pack's publication
  bool in_use_published = false;  // (the full pack) this round's in-use pack is the one in the output directory

  std::string text(const char* what) const {
    std::ostringstream out;
    out << what << ": ";
    switch (outcome) {
      case Outcome::NotRun: out << "not built"; break;
      case Outcome::NoUsageLog: out << "no usage log yet"; break;
      case Outcome::Restarted: out << "restarted (inputs changed during the round)"; break;
      case Outcome::Stopped: out << "not built (stopping)"; break;
      case Outcome::Failed:
        out << "failed (" << counted(static_cast<size_t>(errors), "error", "errors") << "; "
            << (in_use_published ? "the in-use pack stays)" : "the pack is left as it was)");
        break;
      case Outcome::UpToDate:
      case Outcome::Built:
        out << counted(variants, "variant", "variants") << " (";
        if (outcome == Outcome::UpToDate) out << "up to date";
        else out << counted(compiled, "stage source", "stage sources") << " compiled, " << cache_hits << " from the cache";
        out << "), " << std::fixed << std::setprecision(2) << seconds << " s";
        break;
    }
    return out.str();
  }
};

class Watcher {
 public:
  Watcher(BuildOptions options, std::vector<fs::path> usage_logs, int signals)
      : options_(std::move(options)), usage_logs_(std::move(usage_logs)), signals_(signals),
        inputs_({canonical_or_absolute(options_.output_dir),
                 options_.cache_dir ? canonical_or_absolute(*options_.cache_dir) : fs::path()}) {  // empty: none
    options_.usage_logs.clear();  // the full pack; the in-use one adds the logs, read again each round
  }

  int run() {
    if (!inputs_.open()) {
      std::cerr << "kiln: error: cannot watch the inputs: inotify_init1: " << std::strerror(errno) << "\n";
      return exit_status(ExitClass::Environment);
    }
    // Until the first build says what it read, any change beside the pack definition starts the next round.
    inputs_.watch({options_.pack_file}, true);
    Changes changes;
    changes.first_seen = Clock::now();
    for (unsigned round = 1;; ++round) {
      if (build_round(round, changes)) return 0;
      if (!wait_for_changes(changes)) return 0;
    }
  }

 private:
  // A round: the in-use pack (with --usage), then the full one. `changes` starts the round and holds, after it,
  // what changed during it (the next round's start). True when a signal came and watch should end.
  bool build_round(unsigned round, Changes& changes) {
    const std::string what = round == 1 ? "start" : changes.text();
    const Clock::time_point since = changes.first_seen;
    Phase in_use, full;
    std::set<std::string> said;  // the in-use build's diagnostics, not printed again by the full one
    std::vector<fs::path> read;  // what the last build of the round read
    const Phase* last = &in_use;
    if (!usage_logs_.empty()) {
      BuildOptions narrowed = options_;
      for (const fs::path& log : usage_logs_) {
        std::error_code ec;
        if (fs::exists(log, ec)) narrowed.usage_logs.push_back(log);  // a game that has not run yet has written none
      }
      if (narrowed.usage_logs.empty()) in_use.outcome = Phase::Outcome::NoUsageLog;
      else read = build(narrowed, since, said, in_use);
    }
    // What changed while the in-use pack was built restarts the round: the full pack of inputs already stale would
    // be replaced at once. The next round starts right after this one, once the quiet period has passed.
    Changes during;
    if (last->outcome != Phase::Outcome::NotRun && last->outcome != Phase::Outcome::NoUsageLog) {
      inputs_.read(during);
      during.settle();
    }
    if (signalled()) {
      full.outcome = Phase::Outcome::Stopped;
    } else if (!during.empty()) {
      full.outcome = Phase::Outcome::Restarted;
    } else {
      full.in_use_published = in_use.outcome == Phase::Outcome::Built || in_use.outcome == Phase::Outcome::UpToDate;
      read = build(options_, since, said, full);
      last = &full;
    }
    // A failed build may have stopped before reading everything (a missing include ends the plan), and a restarted
    // round built nothing: what the last good build read stays watched, and any change there starts the next round.
    const bool good = last->outcome == Phase::Outcome::Built || last->outcome == Phase::Outcome::UpToDate;
    std::erase_if(read, [&](const fs::path& input) {  // usage logs are read again each round: the game writing one starts none
      return std::any_of(usage_logs_.begin(), usage_logs_.end(),
                         [&](const fs::path& log) { return canonical_or_absolute(log) == canonical_or_absolute(input); });
    });
    read.push_back(options_.pack_file);
    if (good) last_good_inputs_ = read;
    else read.insert(read.end(), last_good_inputs_.begin(), last_good_inputs_.end());
    inputs_.watch(read, !good);
    std::cout << "kiln watch: round " << round << ": " << what;
    if (!usage_logs_.empty()) std::cout << "; " << in_use.text("in use");
    std::cout << "; " << full.text("full") << "; watching " << counted(inputs_.files(), "file", "files") << " in "
              << counted(inputs_.directories(), "directory", "directories") << std::endl;
    changes = std::move(during);
    return full.outcome == Phase::Outcome::Stopped || signalled();
  }

  // One build_pack; its diagnostics printed as they come (but those `said` already holds). Returns what it read.
  std::vector<fs::path> build(const BuildOptions& options, Clock::time_point since, std::set<std::string>& said, Phase& phase) {
    DiagnosticSink sink;
    sink.set_listener([&said](const Diagnostic& d) {
      if (said.insert(format_diagnostic(d)).second) std::cerr << format_diagnostic(d, colour()) << std::flush;
    });
    BuildReport report = build_pack(options, sink);
    phase.seconds = std::chrono::duration<double>(Clock::now() - since).count();
    phase.variants = report.funnel.kept;
    phase.compiled = report.compiled;
    phase.cache_hits = report.cache_hits;
    phase.errors = sink.error_count();
    phase.outcome = !report.ok ? Phase::Outcome::Failed : report.up_to_date ? Phase::Outcome::UpToDate : Phase::Outcome::Built;
    return std::move(report.dependencies);
  }

  bool signalled() {
    pollfd entry{signals_, POLLIN, 0};
    return ::poll(&entry, 1, 0) > 0;
  }

  // Waits for a change to the inputs and then for the quiet period after the last one (`changes` may hold what a
  // restarted round saw already). False when SIGINT or SIGTERM came instead.
  bool wait_for_changes(Changes& changes) {
    pollfd entries[2] = {{inputs_.fd(), POLLIN, 0}, {signals_, POLLIN, 0}};
    Clock::time_point quiet_from = Clock::now();
    for (;;) {
      int timeout = -1;
      if (changes.pending()) {
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(quiet_from + defaults::kWatchQuietPeriod - Clock::now());
        timeout = static_cast<int>(std::max<long>(0, left.count()));
      }
      const int ready = ::poll(entries, 2, timeout);
      if (ready < 0) {
        if (errno == EINTR) continue;
        std::cerr << "kiln: error: watching the inputs: poll: " << std::strerror(errno) << "\n";
        return false;
      }
      if (entries[1].revents) return false;
      if (ready == 0) {  // quiet for the whole period: build, unless all that came were temporary files
        changes.settle();
        if (!changes.empty()) return true;
        continue;
      }
      const size_t before = changes.names.size() + changes.more + changes.maybe.size();
      inputs_.read(changes);
      if (changes.names.size() + changes.more + changes.maybe.size() != before) quiet_from = Clock::now();
    }
  }

  BuildOptions options_;
  std::vector<fs::path> usage_logs_;
  int signals_;
  InputWatch inputs_;
  std::vector<fs::path> last_good_inputs_;
};

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
    // SIGINT and SIGTERM wait in a signalfd, read between builds: a build under way finishes (its pack is written
    // whole or not at all) and watch ends with 0. Blocked before any worker starts, so the workers (which inherit the
    // mask) are not cut off mid-job by a terminal's Ctrl-C either; they end when kiln closes their pipes.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGINT);
    sigaddset(&signals, SIGTERM);
    if (::pthread_sigmask(SIG_BLOCK, &signals, nullptr) != 0) return exit_status(ExitClass::Environment);
    Descriptor signal_fd(::signalfd(-1, &signals, SFD_NONBLOCK | SFD_CLOEXEC));
    if (signal_fd.get() < 0) {
      std::cerr << "kiln: error: cannot wait for signals: signalfd: " << std::strerror(errno) << "\n";
      return exit_status(ExitClass::Environment);
    }
    std::vector<fs::path> logs(usage_logs_.begin(), usage_logs_.end());
    return Watcher(options_, std::move(logs), signal_fd.get()).run();
  }

 private:
  BuildOptions options_;
  PlanArguments plan_;
  std::string pack_file_, output_, cache_dir_;
  std::string recipe_name_{optimizer_recipe_name(OptimizerRecipe::Kiln)};
  std::vector<std::string> target_names_, usage_logs_, usage_tags_;
  bool no_cache_ = false;
  double timeout_s_ = std::chrono::duration<double>(defaults::kWorkerTimeout).count();
};

}  // namespace

std::unique_ptr<Verb> make_watch_verb() { return std::make_unique<WatchVerb>(); }

}  // namespace kiln::cli
