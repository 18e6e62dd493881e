// SPDX-License-Identifier: Apache-2.0
// kiln watch (kiln/watch.hpp, docs/development-loop.md): builds a pack, then watches every input the build read and
// builds again on each change, the variants in use first (--usage and the variants readers asked for: published as
// soon as they are done), then the full pack. Event-driven and bounded (STYLE.md rule 19): one inotify descriptor on
// the directories that hold the inputs, a signalfd for SIGINT and SIGTERM and, with a development endpoint, the
// HTTP server's epoll descriptor, all in one poll(); nothing sleeps, and a round holds nothing the next one keeps.
#include "kiln/watch.hpp"

#include <arpa/inet.h>
#include <poll.h>
#include <sys/inotify.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "kiln/defaults.hpp"
#include "kiln/files.hpp"
#include "kiln/output_file.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/usage_log.hpp"
#include "watch/development_server.hpp"

namespace kiln {
namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

// At most this many changed names are listed in a status line (a checkout touching 500 files is "and 495 more").
constexpr size_t kListedChanges = 8;

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
  // Cancelled: interrupted, before Watcher::build_full says by what (Restarted, Interrupted or Stopped).
  enum class Outcome { NotRun, Built, UpToDate, Failed, Restarted, Interrupted, Stopped, NoUsageLog, Cancelled } outcome =
      Outcome::NotRun;
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
      case Outcome::Interrupted: out << "interrupted by a variant request (built again after it)"; break;
      case Outcome::Cancelled:
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

// The pack's name, for the endpoint file and the requests' usage log: the definition's "name", else its file name.
std::string pack_name_of(const fs::path& pack_file) {
  std::ifstream in(pack_file, std::ios::binary);
  std::string text(64 * 1024, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(in.gcount()));
  try {
    const nlohmann::json json = nlohmann::json::parse(text);
    if (json.is_object() && json.contains("name") && json["name"].is_string()) return json["name"].get<std::string>();
  } catch (const nlohmann::json::exception&) {  // the build says what is wrong with it
  }
  std::string name = pack_file.filename().string();
  if (name.ends_with(".pack.json")) name.resize(name.size() - 10);
  return name;
}

std::string keyword_text(const std::vector<std::string>& keywords) {
  std::string text;
  for (const std::string& keyword : keywords) text += (text.empty() ? "" : " ") + keyword;
  return "[" + text + "]";
}

class Watcher {
 public:
  Watcher(const WatchOptions& options, int signals, const WatchListener& listener)
      : options_(options.build), usage_logs_(options.usage_logs), serve_(options.serve), in_use_only_(options.in_use_only),
        signals_(signals), listener_(listener), pack_name_(pack_name_of(options.build.pack_file)),
        inputs_({canonical_or_absolute(options_.output_dir),
                 options_.cache_dir ? canonical_or_absolute(*options_.cache_dir) : fs::path()}) {  // empty: none
    options_.usage_logs.clear();  // the full pack; the in-use one adds the logs, read again each round
  }

  int run() {
    if (!inputs_.open())
      return fail(DiagId::WatchUnavailable, std::string("cannot watch the inputs: inotify_init1: ") + std::strerror(errno));
    if (serve_ && !start_serving()) return exit_status(ExitClass::Environment);
    // Until the first build says what it read, any change beside the pack definition starts the next round.
    inputs_.watch({options_.pack_file}, true);
    Changes changes;
    changes.first_seen = Clock::now();
    int status = 0;
    for (unsigned round = 1;; ++round) {
      if (build_round(round, changes)) break;
      Wake wake = wait_for_changes(changes);
      while (wake == Wake::FullPackOwed) {  // requests published in-use packs: the full pack follows
        Phase full;
        full.in_use_published = true;  // the requests' in-use pack
        std::set<std::string> said;
        build_full(Clock::now(), said, full, changes);
        say("kiln watch: after requests; " + full.text("full"));
        wake = full.outcome == Phase::Outcome::Stopped ? Wake::Stop : wait_for_changes(changes);
      }
      if (wake == Wake::Stop) break;
      if (wake == Wake::Error) {
        status = exit_status(ExitClass::Environment);
        break;
      }
    }
    std::error_code ec;
    if (server_) fs::remove(development::endpoint_file(options_.output_dir, pack_name_), ec);  // no stale endpoint left
    return status;
  }

 private:
  enum class Wake { Changes, Stop, FullPackOwed, Error };

  // An error of watch's own (K1801, K1802, K1601) that ends it, or a warning (K1803).
  int fail(DiagId id, const std::string& message) {
    Diagnostic diagnostic;  // no location: watch's own (member by member: GCC's -O3 sees the aggregate's string as unset)
    diagnostic.id = id;
    diagnostic.severity = diagnostic_info(id).severity;
    diagnostic.message = message;
    if (listener_.diagnostic) listener_.diagnostic(diagnostic);
    return exit_status(diagnostic_info(id).exit_class);
  }
  void say(const std::string& line) {
    if (listener_.status) listener_.status(line);
  }

  bool start_serving() {
    development::DevelopmentServer::Handlers handlers{
        [this](const development::VariantRequest& request) { return serve(request); },
        [this](const development::SelectedReport& report) { return take_report(report); }};
    auto server = development::DevelopmentServer::start(*serve_, std::move(handlers));
    if (!server) {
      fail(DiagId::EndpointUnavailable, server.error().message);
      return false;
    }
    server_ = std::move(*server);
    const fs::path file = development::endpoint_file(options_.output_dir, pack_name_);
    std::error_code ec;
    fs::create_directories(options_.output_dir, ec);
    if (Result<void> written = write_output_file(file, server_->endpoint().text() + "\n"); !written) {
      fail(DiagId::OutputUnwritable, written.error().message);
      return false;
    }
    say("kiln watch: serving variants on http://" + server_->endpoint().text() + development::kVariantPath + " (" +
        display_path(file) + ")");
    return true;
  }

  fs::path manifest_file() const { return options_.output_dir / (pack_name_ + ".manifest.json"); }

  // The in-use pack's options: the usage logs there are, and the variants readers asked for and selected.
  std::optional<BuildOptions> in_use_options() {
    BuildOptions narrowed = options_;
    for (const fs::path& log : usage_logs_) {
      std::error_code ec;
      if (fs::exists(log, ec)) narrowed.usage_logs.push_back(log);  // a game that has not run yet has written none
    }
    if (!requested_.empty() || selected_count_ > 0) narrowed.usage_logs.push_back(requests_log());
    if (narrowed.usage_logs.empty()) return std::nullopt;
    return narrowed;
  }

  // The variants readers asked for and selected, as a usage log beside the pack (what the in-use build reads).
  fs::path requests_log() const { return options_.output_dir / (pack_name_ + ".requested.usage.json"); }
  bool write_requests_log() {
    std::set<Key> in_use = requested_;
    for (const auto& [client, reader] : selected_) in_use.insert(reader.variants.begin(), reader.variants.end());
    std::map<std::string, usage_log::Pass> passes;
    for (const auto& [pass, keywords] : in_use) {
      passes[pass].name = pass;
      passes[pass].served.push_back({keywords, 1, {}});
    }
    std::vector<usage_log::Pass> list;
    for (auto& [name, pass] : passes) list.push_back(std::move(pass));
    return bool(write_output_file(requests_log(), usage_log::text(pack_name_, {}, std::move(list), 0)));
  }

  // A variant a reader asked for: from the pack there is when it has it, else from an in-use build with it. During
  // the full-pack build, a request that needs a build is held (no answer): the full build stops, the request is
  // served, and the full build runs again.
  std::optional<development::Answer> serve(const development::VariantRequest& request) {
    const Clock::time_point since = Clock::now();
    const std::string what = "kiln watch: request " + request.pass + " " + keyword_text(request.keywords) + ": ";
    auto in_pack = [&]() -> Result<std::string, PackError> {  // the archive that serves it
      PackResult<PackReader> reader = PackReader::try_open(manifest_file());
      if (!reader) return failure(reader.error());
      PackResult<SelectedVariant> selected = reader->try_select(request.pass, request.keywords, true);
      if (!selected) return failure(selected.error());
      PackResult<PackUpdate> served_now = reader->poll_update();  // names the archive without parsing the manifest
      if (!served_now) return failure(served_now.error());
      return served_now->archive;
    };
    auto served = [&](const std::string& archive, bool compiled) {
      const double seconds = std::chrono::duration<double>(Clock::now() - since).count();
      std::ostringstream line;
      line << what << (compiled ? "built into " : "in ") << archive << ", " << std::fixed << std::setprecision(2) << seconds << " s";
      say(line.str());
      return development::Answer{200, nlohmann::json{{"version", 1}, {"pass", request.pass}, {"keywords", request.keywords},
                                               {"archive", archive}, {"compiled", compiled}}.dump()};
    };
    Result<std::string, PackError> found = in_pack();
    if (found) return served(*found, false);
    const PackError::Code code = found.error().code();
    if (code == PackError::Code::ConflictingKeywords || code == PackError::Code::MissingKeyword) {
      say(what + "refused: " + found.error().what());
      return development::error_answer(400, found.error().what());
    }
    const auto key = std::make_pair(request.pass, request.keywords);
    // A keyword the pass does not declare is in no pack of these inputs (a pack's index declares every keyword of
    // each pass it has, used or not); what an in-use build refused this round is refused again without a build.
    if (code == PackError::Code::UnknownKeyword || refused_.count(key)) {
      say(what + "refused: " + found.error().what());
      return development::error_answer(404, found.error().what());
    }
    if (building_full_) {
      say(what + "held: the full build stops for it");
      holding_request_ = true;
      return std::nullopt;
    }
    const bool added = requested_.insert(key).second;
    if (requested_.size() > development::kMaxRequestedVariants) {
      requested_.erase(key);
      const std::string message = "kiln watch holds " + std::to_string(development::kMaxRequestedVariants) + " requested variants already";
      warn_in_use_set_full(message);
      return development::error_answer(503, message);
    }
    if (added && !write_requests_log()) {
      requested_.erase(key);
      return development::error_answer(500, "cannot write " + display_path(requests_log()));
    }
    Phase phase;
    std::set<std::string> said;
    std::string diagnostics;
    std::optional<BuildOptions> narrowed = in_use_options();
    build(*narrowed, since, said, phase, &diagnostics);
    if (phase.outcome == Phase::Outcome::Failed) {
      say(what + "the in-use build failed (" + counted(static_cast<size_t>(phase.errors), "error", "errors") + ")");
      return development::error_answer(422, "the in-use build failed; the pack is left as it was", diagnostics);
    }
    if (!in_use_only_) full_pack_owed_ = true;
    found = in_pack();
    if (found) return served(*found, true);
    requested_.erase(key);  // no variant of the pack: kept out of later rounds
    write_requests_log();
    if (refused_.size() < development::kMaxRequestedVariants) refused_.insert(key);
    say(what + "refused: " + found.error().what());
    return development::error_answer(404, found.error().what());
  }

  // What a reader in development mode selected since its last report (DevelopmentReader::poll_update): the
  // variants the pack it reads has, or lacks but could build (Stripped), join the in-use set of the next round. No
  // build now: the reader has what it selected. Bounded per reader and over all (a reader over its share, or a new
  // reader when the others hold everything, is told how many were dropped; K1803 once), and only names the pack's
  // index declares are kept, so a hostile report adds nothing the pack cannot have.
  development::Answer take_report(const development::SelectedReport& report) {
    PackResult<PackReader> reader = PackReader::try_open(manifest_file());
    if (!reader) return development::error_answer(503, "no pack to check the report against yet: " + reader.message());
    if (!selected_.count(report.client) && selected_.size() == development::kMaxSelectedReaders) {
      auto oldest = std::min_element(selected_.begin(), selected_.end(),
                                     [](const auto& a, const auto& b) { return a.second.last_report < b.second.last_report; });
      selected_count_ -= oldest->second.variants.size();
      selected_.erase(oldest);
    }
    SelectedByReader& mine = selected_[report.client];
    mine.last_report = ++reports_;
    size_t added = 0, unknown = 0, dropped = 0;
    for (const development::VariantRequest& variant : report.selected) {
      Key key{variant.pass, variant.keywords};
      if (mine.variants.count(key)) continue;
      PackResult<SelectedVariant> selected = reader->try_select(variant.pass, variant.keywords, true);
      if (!selected && selected.code() != PackError::Code::Stripped) {
        ++unknown;
        continue;
      }
      if (mine.variants.size() >= development::kMaxSelectedPerReader || selected_count_ >= development::kMaxSelectedVariants) {
        ++dropped;
        continue;
      }
      mine.variants.insert(std::move(key));
      ++selected_count_;
      ++added;
    }
    if (added && !write_requests_log()) return development::error_answer(500, "cannot write " + display_path(requests_log()));
    std::string line = "kiln watch: reader " + report.client + ": " + counted(report.selected.size(), "variant", "variants") +
                       " selected, " + std::to_string(added) + " new in the in-use set (" + std::to_string(selected_count_) + " selected";
    if (unknown) line += "; " + std::to_string(unknown) + " not of this pack";
    if (dropped) line += "; " + std::to_string(dropped) + " over the bound";
    say(line + ")");
    if (dropped)
      warn_in_use_set_full("reader " + report.client + " selected more variants than the in-use set holds (" +
                           std::to_string(development::kMaxSelectedPerReader) + " a reader, " +
                           std::to_string(development::kMaxSelectedVariants) + " in all): " + std::to_string(dropped) +
                           " are built with the full pack only");
    return development::Answer{200, nlohmann::json{{"version", 1}, {"added", added}, {"unknown", unknown}, {"dropped", dropped},
                                                   {"selected", selected_count_}}.dump()};
  }

  void warn_in_use_set_full(const std::string& message) {
    if (warned_full_) return;
    warned_full_ = true;
    fail(DiagId::InUseSetFull, message);
  }

  // A round: the in-use pack (with --usage or requests), then the full one. `changes` starts the round and holds,
  // after it, what changed during it (the next round's start). True when a signal came and watch should end.
  bool build_round(unsigned round, Changes& changes) {
    const std::string what = round == 1 ? "start" : changes.text();
    const Clock::time_point since = changes.first_seen;
    refused_.clear();  // the inputs changed: a pass or variant refused before may be there now
    Phase in_use, full;
    std::set<std::string> said;  // the in-use build's diagnostics, not printed again by the full one
    std::vector<fs::path> read;  // what the last build of the round read
    const Phase* last = &in_use;
    const bool has_in_use = !usage_logs_.empty() || server_;
    if (has_in_use) {
      std::optional<BuildOptions> narrowed = in_use_options();
      if (!narrowed) in_use.outcome = Phase::Outcome::NoUsageLog;
      else read = build(*narrowed, since, said, in_use);
    }
    // What changed while the in-use pack was built restarts the round: the full pack of inputs already stale would
    // be replaced at once. The next round starts right after this one, once the quiet period has passed.
    Changes during;
    if (last->outcome != Phase::Outcome::NotRun && last->outcome != Phase::Outcome::NoUsageLog) {
      inputs_.read(during);
      during.settle();
    }
    if (server_) server_->run();  // requests that came during the in-use build: served before the full one starts
    if (signalled()) {
      full.outcome = Phase::Outcome::Stopped;
    } else if (!during.empty()) {
      full.outcome = Phase::Outcome::Restarted;
    } else if (in_use_only_ && in_use.outcome != Phase::Outcome::NoUsageLog) {
      full.outcome = Phase::Outcome::NotRun;
    } else {
      full.in_use_published = in_use.outcome == Phase::Outcome::Built || in_use.outcome == Phase::Outcome::UpToDate;
      read = build_full(since, said, full, during);
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
    std::string line = "kiln watch: round " + std::to_string(round) + ": " + what;
    if (has_in_use) line += "; " + in_use.text("in use");
    if (!in_use_only_ || full.outcome != Phase::Outcome::NotRun) line += "; " + full.text("full");
    line += "; watching " + counted(inputs_.files(), "file", "files") + " in " +
            counted(inputs_.directories(), "directory", "directories");
    say(line);
    changes = std::move(during);
    return full.outcome == Phase::Outcome::Stopped || signalled();
  }

  // One build_pack; its diagnostics reported as they come (but those `said` already holds), and kept in
  // `diagnostics` when given. Returns what it read.
  std::vector<fs::path> build(const BuildOptions& options, Clock::time_point since, std::set<std::string>& said, Phase& phase,
                              std::string* diagnostics = nullptr) {
    DiagnosticSink sink;
    sink.set_listener([&](const Diagnostic& d) {
      const std::string text = format_diagnostic(d);
      if (diagnostics && diagnostics->size() < development::kMaxAnswerBytes) *diagnostics += text;
      if (said.insert(text).second && listener_.diagnostic) listener_.diagnostic(d);
    });
    BuildReport report = build_pack(options, sink);
    phase.seconds = std::chrono::duration<double>(Clock::now() - since).count();
    phase.variants = report.funnel.kept;
    phase.compiled = report.compiled;
    phase.cache_hits = report.cache_hits;
    phase.errors = sink.error_count();
    phase.outcome = report.cancelled ? Phase::Outcome::Cancelled
                    : !report.ok     ? Phase::Outcome::Failed
                    : report.up_to_date ? Phase::Outcome::UpToDate
                                        : Phase::Outcome::Built;
    return std::move(report.dependencies);
  }

  // The full pack's build, interrupted by what makes it stale or keeps someone waiting: a change to an input (into
  // `during`: Restarted, the next round builds it), a variant request that needs a build (held and served once the
  // build stopped: Interrupted, and the full pack is built again after the requests), SIGINT or SIGTERM (Stopped).
  // The workers' scheduler asks after each job and whenever one of these descriptors is readable; the jobs in flight
  // finish (their results go into the cache), so the build that follows starts where this one stopped.
  std::vector<fs::path> build_full(Clock::time_point since, std::set<std::string>& said, Phase& phase, Changes& during) {
    enum class Why { None, Changes, Request, Signal } why = Why::None;
    BuildOptions options = options_;
    options.interruption.fds = {inputs_.fd(), signals_};
    if (server_) options.interruption.fds.push_back(server_->fd());
    options.interruption.check = [&] {
      if (why != Why::None) return true;
      if (signalled()) why = Why::Signal;  // not read: run() and build_round see it after the build
      if (why == Why::None) inputs_.read(during);
      if (why == Why::None && !during.empty()) why = Why::Changes;
      if (why == Why::None && server_) {
        server_->run();  // reports are answered; a variant request that needs a build is held
        if (holding_request_) why = Why::Request;
      }
      return why != Why::None;
    };
    building_full_ = true;
    std::vector<fs::path> read = build(options, since, said, phase);
    building_full_ = false;
    holding_request_ = false;
    full_pack_owed_ = false;
    if (server_) server_->release_held();  // served by the next run(), from wait_for_changes
    if (phase.outcome == Phase::Outcome::Cancelled) {
      phase.outcome = why == Why::Signal ? Phase::Outcome::Stopped : why == Why::Request ? Phase::Outcome::Interrupted
                                                                                         : Phase::Outcome::Restarted;
      full_pack_owed_ = why == Why::Request && !in_use_only_;
    }
    return read;
  }

  bool signalled() {
    pollfd entry{signals_, POLLIN, 0};
    return ::poll(&entry, 1, 0) > 0;
  }

  // Waits for a change to the inputs and then for the quiet period after the last one (`changes` may hold what a
  // restarted round saw already), serving requests meanwhile. Stop when SIGINT or SIGTERM came instead;
  // FullPackOwed when requests published in-use packs and no request is open any more.
  Wake wait_for_changes(Changes& changes) {
    pollfd entries[3] = {{inputs_.fd(), POLLIN, 0}, {signals_, POLLIN, 0}, {server_ ? server_->fd() : -1, POLLIN, 0}};
    Clock::time_point quiet_from = Clock::now();
    if (server_) server_->run();  // the requests build_full held and released (their descriptors are not polled)
    for (;;) {
      if (full_pack_owed_ && server_->in_flight() == 0 && !changes.pending()) return Wake::FullPackOwed;
      int timeout = -1;
      if (changes.pending()) {
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(quiet_from + defaults::kWatchQuietPeriod - Clock::now());
        timeout = static_cast<int>(std::max<long>(0, left.count()));
      }
      const int server_timeout = server_ ? server_->timeout_ms() : -1;  // a connection's deadline, not a polling tick
      if (server_timeout >= 0 && (timeout < 0 || server_timeout < timeout)) timeout = server_timeout;
      const int ready = ::poll(entries, server_ ? 3 : 2, timeout);
      if (ready < 0) {
        if (errno == EINTR) continue;
        fail(DiagId::WatchUnavailable, std::string("watching the inputs: poll: ") + std::strerror(errno));
        return Wake::Error;
      }
      if (entries[1].revents) return Wake::Stop;
      if (server_) server_->run();  // what is ready, and the connections whose time is up
      if (entries[0].revents) {
        const size_t before = changes.names.size() + changes.more + changes.maybe.size();
        inputs_.read(changes);
        if (changes.names.size() + changes.more + changes.maybe.size() != before) quiet_from = Clock::now();
      }
      if (changes.pending() && Clock::now() >= quiet_from + defaults::kWatchQuietPeriod) {
        // quiet for the whole period: build, unless all that came were temporary files
        changes.settle();
        if (!changes.empty()) return Wake::Changes;
      }
    }
  }

  BuildOptions options_;
  std::vector<fs::path> usage_logs_;
  std::optional<LoopbackEndpoint> serve_;
  bool in_use_only_;
  int signals_;
  const WatchListener& listener_;
  std::string pack_name_;
  InputWatch inputs_;
  std::vector<fs::path> last_good_inputs_;
  std::unique_ptr<development::DevelopmentServer> server_;
  using Key = std::pair<std::string, std::vector<std::string>>;  // pass, keywords
  struct SelectedByReader {
    std::set<Key> variants;
    uint64_t last_report = 0;  // reports_ when it last reported
  };
  std::set<Key> requested_;                            // by readers, kept for later rounds
  std::set<Key> refused_;                              // built for and not there, this round
  std::map<std::string, SelectedByReader> selected_;   // by reader id, kept for later rounds
  size_t selected_count_ = 0;                          // over all readers
  uint64_t reports_ = 0;
  bool warned_full_ = false;                           // K1803 said
  bool full_pack_owed_ = false;
  bool building_full_ = false;                         // build_full is running: requests that need a build wait
  bool holding_request_ = false;                       // one is held (build_full stops for it)
};

}  // namespace

Result<LoopbackEndpoint> parse_loopback_endpoint(const std::string& text) {
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos) return failure(std::string("expected 127.0.0.1:PORT (PORT 0: any free port)"));
  LoopbackEndpoint endpoint;
  endpoint.host = text.substr(0, colon);
  if (endpoint.host == "localhost") endpoint.host = "127.0.0.1";
  in_addr address{};
  if (::inet_pton(AF_INET, endpoint.host.c_str(), &address) != 1 || (ntohl(address.s_addr) >> 24) != 127)
    return failure("'" + endpoint.host + "' is not a loopback address: the development endpoint listens on 127.0.0.1 only "
                   "(any local process can reach it; docs/threat-model.md)");
  const std::string port = text.substr(colon + 1);
  if (port.empty() || port.size() > 5 || !std::all_of(port.begin(), port.end(), [](char c) { return c >= '0' && c <= '9'; }) ||
      std::stoul(port) > 65535)
    return failure("'" + port + "' is not a port (0 to 65535; 0: any free port)");
  endpoint.port = static_cast<uint16_t>(std::stoul(port));
  return endpoint;
}

fs::path development::endpoint_file(const fs::path& output_dir, const std::string& pack_name) {
  return output_dir / (pack_name + ".endpoint");
}

int watch(const WatchOptions& options, int signal_fd, const WatchListener& listener) {
  return Watcher(options, signal_fd, listener).run();
}

}  // namespace kiln
