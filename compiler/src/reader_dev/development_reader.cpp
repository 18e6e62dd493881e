// SPDX-License-Identifier: Apache-2.0
#include "kiln/development_reader.hpp"

#include <arpa/inet.h>
#include <curl/curl.h>
#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <iterator>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "kiln/bounded_json.hpp"
#include "kiln/development_endpoint.hpp"

namespace kiln {
namespace {

namespace fs = std::filesystem;
using Keywords = std::vector<std::string>;
using Key = std::pair<std::string, Keywords>;  // pass, keywords

using development::kMaxAnswerBytes;
using development::kMaxKeywords;
using development::kMaxNameBytes;
using development::kMaxReportedVariants;
using development::kMaxSelectedPerReader;  // what watch keeps of one reader: no more is sent
constexpr size_t kMaxSelectedLogBytes = 16 << 20;  // the usage log read back (the reader's own, bounded by its pack)
constexpr size_t kMaxPending = 64;     // background requests queued: more are dropped (asked again on a later miss)
constexpr size_t kMaxAsked = 4096;     // keyword sets remembered as asked for
constexpr size_t kMaxEndpointFile = 256;

// A PackError as the PackResult of any value type.
struct Failed {
  PackError error;
  template <class T>
  operator PackResult<T>() const {  // NOLINT(google-explicit-constructor)
    return PackResult<T>(error.code(), error.what(), error.file());
  }
};
Failed failed(const PackError& error) { return Failed{error}; }

PackError io_error(const std::string& message) { return PackError(PackError::Code::Io, "development endpoint: " + message); }

// "127.x.y.z:PORT", or an error: development mode talks to the local machine only, whatever a file or variable says.
std::optional<std::string> loopback_endpoint(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) text.pop_back();
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon + 1 == text.size() || text.size() - colon - 1 > 5) return std::nullopt;
  const std::string host = text.substr(0, colon), port = text.substr(colon + 1);
  in_addr address{};
  if (::inet_pton(AF_INET, host.c_str(), &address) != 1 || (ntohl(address.s_addr) >> 24) != 127) return std::nullopt;
  if (!std::all_of(port.begin(), port.end(), [](char c) { return c >= '0' && c <= '9'; }) || std::stoul(port) == 0 ||
      std::stoul(port) > 65535)
    return std::nullopt;
  return text;
}

// A name watch takes (development::is_protocol_name): a keyword set with another is not reported, rather than have
// watch refuse the whole report.
bool is_protocol_name(const std::string& text) {
  if (text.empty() || text.size() > kMaxNameBytes) return false;
  return std::all_of(text.begin(), text.end(), [](char c) { return c > ' ' && c < 0x7f && c != '"' && c != '\\'; });
}

// This reader's id in its reports: its process and a random number, so that a restarted game is a new reader.
std::string make_client_id() {
  std::random_device random;
  const uint64_t number = (uint64_t(random()) << 32) ^ random();
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(number));
  return std::to_string(::getpid()) + "-" + hex;
}

// Where the usage log of a reader that records for its reports only goes: the user's runtime directory (a tmpfs
// of the user's own), else the temporary directory.
fs::path own_selected_log(const std::string& client) {
  std::error_code ec;
  const char* runtime = std::getenv("XDG_RUNTIME_DIR");
  fs::path directory = runtime && *runtime && fs::is_directory(runtime, ec) ? fs::path(runtime) : fs::temp_directory_path(ec);
  return directory / ("kiln-selected-" + client + ".usage.json");
}

size_t keep_bounded(char* data, size_t size, size_t count, void* user) {
  auto& body = *static_cast<std::string*>(user);
  if (body.size() + size * count > kMaxAnswerBytes) return 0;  // ends the transfer: CURLE_WRITE_ERROR
  body.append(data, size * count);
  return size * count;
}

bool is_archive_name(const std::string& name) {  // "<pack>.<16 hex digits>.kpack", a file name and no path
  if (name.size() > 512 || !name.ends_with(".kpack") || name.find('/') != std::string::npos || name.find('\0') != std::string::npos)
    return false;
  const size_t dot = name.rfind('.', name.size() - 7);
  return dot != std::string::npos && name.size() - 6 - dot - 1 == 16 &&
         std::all_of(name.begin() + static_cast<long>(dot) + 1, name.end() - 6, [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
}

}  // namespace

struct DevelopmentReader::Impl {
  PackReader* reader = nullptr;
  fs::path manifest;
  Options options;

  mutable std::mutex mutex;
  std::condition_variable wake;
  std::deque<std::pair<std::string, Keywords>> queue;
  std::set<std::pair<std::string, Keywords>> asked;
  size_t in_flight = 0;
  std::string last_error;
  bool stopping = false;
  std::thread thread;

  // Reports (report_selected): the game's thread reads the log, the background thread sends what is new.
  std::string client;
  fs::path selected_log;
  bool own_log = false;             // recording was started by open() for the reports alone
  std::mutex report_mutex;          // one report_selected() at a time; it skips when another runs
  std::chrono::steady_clock::time_point last_read{};  // under report_mutex
  std::set<Key> reported;           // taken by watch (under `mutex`)
  std::vector<Key> report;          // to send (under `mutex`)
  bool reporting = false;           // a report queued or under way (under `mutex`)
  size_t logged_sets = SIZE_MAX;    // the log's keyword sets when all of them had been reported (under `mutex`)
  size_t sending_sets = SIZE_MAX;   // the same for the report under way, if it takes the rest (under `mutex`)

  ~Impl() {
    {
      std::lock_guard lock(mutex);
      stopping = true;
    }
    wake.notify_all();
    if (thread.joinable()) thread.join();
    if (own_log) {  // no log is left behind: the reader's last flush (when it goes) has no file to write
      try {
        reader->record_usage({});
      } catch (const std::bad_alloc&) {
      }
      std::error_code ec;
      fs::remove(selected_log, ec);
    }
  }

  PackResult<std::string> endpoint() const {
    if (!options.endpoint.empty()) {
      if (auto endpoint = loopback_endpoint(options.endpoint)) return *endpoint;
      return failed(io_error("'" + options.endpoint + "' is not 127.0.0.1:PORT"));
    }
    std::string name = manifest.filename().string();
    if (name.ends_with(".manifest.json")) name.resize(name.size() - 14);
    const fs::path file = manifest.parent_path() / (name + ".endpoint");
    std::ifstream in(file, std::ios::binary);
    if (!in) return failed(io_error("no " + file.string() + ": is kiln watch --serve running on this pack?"));
    std::string text(kMaxEndpointFile, '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<size_t>(in.gcount()));
    if (auto endpoint = loopback_endpoint(text)) return *endpoint;
    return failed(io_error(file.string() + " does not hold 127.0.0.1:PORT"));
  }

  // The keywords of `keywords` that the pass declares (select ignores the others, watch would refuse them).
  Keywords declared(std::string_view pass, const Keywords& keywords) const {
    std::set<std::string> names;
    PackResult<std::vector<Keywords>> groups = reader->try_keyword_groups(pass);
    if (groups)
      for (const Keywords& group : *groups) names.insert(group.begin(), group.end());
    Keywords kept;
    for (const std::string& keyword : keywords)
      if (names.count(keyword)) kept.push_back(keyword);
    std::sort(kept.begin(), kept.end());
    kept.erase(std::unique(kept.begin(), kept.end()), kept.end());
    return kept;
  }

  // One POST to watch; the answer checked before anything in it is used: a JSON object with status 200, else watch's
  // refusal (Stripped, in watch's words) or the transfer's error (Io).
  PackResult<nlohmann::json> exchange(const char* path, const std::string& body, std::chrono::milliseconds timeout) const {
    PackResult<std::string> where = endpoint();
    if (!where) return failed(where.error());
    static std::once_flag initialized;
    std::call_once(initialized, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
    std::unique_ptr<CURL, void (*)(CURL*)> curl(curl_easy_init(), curl_easy_cleanup);
    if (!curl) return failed(io_error("curl_easy_init failed"));
    const std::string url = "http://" + *where + path;
    std::string answer;
    std::unique_ptr<curl_slist, void (*)(curl_slist*)> headers(curl_slist_append(nullptr, "Content-Type: application/json"),
                                                             curl_slist_free_all);
    curl_easy_setopt(curl.get(), CURLOPT_URL, url.c_str());
    curl_easy_setopt(curl.get(), CURLOPT_PROTOCOLS_STR, "http");
    curl_easy_setopt(curl.get(), CURLOPT_NOPROXY, "*");  // a proxy from the environment would take it off the machine
    curl_easy_setopt(curl.get(), CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(curl.get(), CURLOPT_HTTPHEADER, headers.get());
    curl_easy_setopt(curl.get(), CURLOPT_POSTFIELDS, body.c_str());
    curl_easy_setopt(curl.get(), CURLOPT_POSTFIELDSIZE, static_cast<long>(body.size()));
    curl_easy_setopt(curl.get(), CURLOPT_TIMEOUT_MS, static_cast<long>(std::max<long>(1, timeout.count())));
    curl_easy_setopt(curl.get(), CURLOPT_WRITEFUNCTION, &keep_bounded);
    curl_easy_setopt(curl.get(), CURLOPT_WRITEDATA, &answer);
    const CURLcode result = curl_easy_perform(curl.get());
    if (result == CURLE_WRITE_ERROR) return failed(io_error("the answer is over " + std::to_string(kMaxAnswerBytes) + " bytes"));
    if (result != CURLE_OK) return failed(io_error(url + ": " + curl_easy_strerror(result)));
    long status = 0;
    curl_easy_getinfo(curl.get(), CURLINFO_RESPONSE_CODE, &status);
    nlohmann::json json;
    try {
      json = parse_json_bounded(answer, {kMaxAnswerBytes, 3});
    } catch (const JsonDecodeError& error) {
      return failed(io_error("the answer (HTTP " + std::to_string(status) + ") is not JSON: " + error.what()));
    }
    if (!json.is_object()) return failed(io_error("the answer is not a JSON object"));
    if (status != 200) {
      std::string message = json.contains("error") && json["error"].is_string() ? json["error"].get<std::string>() : "no error given";
      if (json.contains("diagnostics") && json["diagnostics"].is_string()) message += "\n" + json["diagnostics"].get<std::string>();
      return failed(PackError(PackError::Code::Stripped, "kiln watch (HTTP " + std::to_string(status) + "): " +
                                                              message.substr(0, kMaxAnswerBytes)));
    }
    return json;
  }

  // One POST /v1/variant: the archive watch published with the variant.
  PackResult<std::string> post(std::string_view pass, const Keywords& keywords, std::chrono::milliseconds timeout) const {
    PackResult<nlohmann::json> json = exchange(development::kVariantPath, nlohmann::json{{"pass", pass}, {"keywords", keywords}}.dump(), timeout);
    if (!json) return failed(json.error());
    if (!json->contains("archive") || !(*json)["archive"].is_string() || !is_archive_name((*json)["archive"].get<std::string>()))
      return failed(io_error("the answer names no archive"));
    return (*json)["archive"].get<std::string>();
  }

  // One POST /v1/selected with `variants`.
  PackResult<nlohmann::json> post_report(const std::vector<Key>& variants) const {
    nlohmann::json selected = nlohmann::json::array();
    for (const auto& [pass, keywords] : variants) selected.push_back(nlohmann::json{{"pass", pass}, {"keywords", keywords}});
    return exchange(development::kSelectedPath, nlohmann::json{{"client", client}, {"selected", std::move(selected)}}.dump(),
                    options.answer_timeout);
  }

  // The keyword sets the usage log holds (served and missing), as watch takes them. Throws JsonDecodeError.
  std::vector<Key> read_selected_log() const {
    std::error_code ec;
    const uintmax_t size = fs::file_size(selected_log, ec);
    if (ec) throw JsonDecodeError("cannot read " + selected_log.string() + ": " + ec.message(), 0);
    if (size > kMaxSelectedLogBytes) throw JsonDecodeError(selected_log.string() + " is over 16 MiB", 0);
    std::ifstream in(selected_log, std::ios::binary);
    std::string text(static_cast<size_t>(size), '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<size_t>(in.gcount()));
    const nlohmann::json log = parse_json_bounded(text, {kMaxSelectedLogBytes, 6});
    std::vector<Key> keys;
    if (!log.is_object() || !log.contains("passes") || !log["passes"].is_array()) return keys;
    for (const nlohmann::json& pass : log["passes"]) {
      if (!pass.is_object() || !pass.contains("name") || !pass["name"].is_string()) continue;
      const std::string name = pass["name"].get<std::string>();
      if (!is_protocol_name(name)) continue;
      for (const char* list : {"served", "missing"}) {
        if (!pass.contains(list) || !pass[list].is_array()) continue;
        for (const nlohmann::json& request : pass[list]) {
          if (!request.is_object() || !request.contains("keywords") || !request["keywords"].is_array() ||
              request["keywords"].size() > kMaxKeywords)
            continue;
          Keywords keywords;
          for (const nlohmann::json& keyword : request["keywords"])
            if (keyword.is_string() && is_protocol_name(keyword.get<std::string>())) keywords.push_back(keyword.get<std::string>());
          if (keywords.size() != request["keywords"].size()) continue;
          std::sort(keywords.begin(), keywords.end());
          keywords.erase(std::unique(keywords.begin(), keywords.end()), keywords.end());
          keys.emplace_back(name, std::move(keywords));
        }
      }
    }
    return keys;
  }

  void report_selected() {
    std::unique_lock guard(report_mutex, std::try_to_lock);
    if (!guard.owns_lock()) return;
    const auto now = std::chrono::steady_clock::now();
    if (last_read != std::chrono::steady_clock::time_point{} && now - last_read < options.report_interval) return;
    {
      std::lock_guard lock(mutex);
      if (reporting) return;
    }
    last_read = now;
    PackResult<size_t> sets = reader->flush_usage();
    if (!sets) {
      std::lock_guard lock(mutex);
      last_error = sets.message();
      return;
    }
    {
      std::lock_guard lock(mutex);
      if (*sets == logged_sets) return;  // no keyword set the game selected is new since everything was reported
    }
    std::vector<Key> logged = read_selected_log();
    std::lock_guard lock(mutex);
    std::vector<Key> unsent;
    for (Key& key : logged)
      if (!reported.count(key)) unsent.push_back(std::move(key));
    const size_t room = kMaxSelectedPerReader - std::min(kMaxSelectedPerReader, reported.size());
    if (unsent.empty() || room == 0) {
      logged_sets = *sets;
      return;
    }
    const size_t taken = std::min({unsent.size(), room, kMaxReportedVariants});
    sending_sets = taken == unsent.size() ? *sets : SIZE_MAX;  // the rest goes in the next report
    unsent.resize(taken);
    report = std::move(unsent);
    reporting = true;
    wake.notify_one();
  }

  void start_thread() {
    thread = std::thread([this] {
      std::unique_lock lock(mutex);
      for (;;) {
        wake.wait(lock, [&] { return stopping || !queue.empty() || !report.empty(); });
        if (stopping) return;
        if (!report.empty()) {
          std::vector<Key> sending = std::move(report);
          report.clear();
          lock.unlock();
          PackResult<nlohmann::json> answer = post_report(sending);
          lock.lock();
          reporting = false;
          if (answer) {
            reported.insert(sending.begin(), sending.end());
            logged_sets = sending_sets;
          } else {
            last_error = answer.message();  // sent again after the next report interval
          }
          continue;
        }
        auto [pass, keywords] = std::move(queue.front());
        queue.pop_front();
        lock.unlock();
        PackResult<std::string> answer = post(pass, keywords, options.answer_timeout);
        lock.lock();
        --in_flight;
        if (!answer) {
          last_error = answer.message();
          asked.erase({pass, keywords});  // asked again on a later miss
        }
      }
    });
  }
};

DevelopmentReader::DevelopmentReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
DevelopmentReader::DevelopmentReader(DevelopmentReader&&) noexcept = default;
DevelopmentReader& DevelopmentReader::operator=(DevelopmentReader&&) noexcept = default;
DevelopmentReader::~DevelopmentReader() = default;

PackResult<DevelopmentReader> DevelopmentReader::open(PackReader& reader, const fs::path& manifest, Options options) {
  auto impl = std::make_unique<Impl>();
  impl->reader = &reader;
  impl->manifest = manifest;
  impl->options = std::move(options);
  if (!impl->options.endpoint.empty() && !loopback_endpoint(impl->options.endpoint))
    return failed(io_error("'" + impl->options.endpoint + "' is not 127.0.0.1:PORT (development mode is loopback only)"));
  impl->client = make_client_id();
  impl->selected_log = impl->options.selected_log;
  if (impl->selected_log.empty()) {  // the game does not record usage: recording for the reports alone
    impl->selected_log = own_selected_log(impl->client);
    impl->own_log = true;
    PackReader::UsageOptions usage;
    usage.file = impl->selected_log;
    reader.record_usage(std::move(usage));
  }
  impl->start_thread();
  return DevelopmentReader(std::move(impl));
}

PackResult<DevelopmentReader> DevelopmentReader::open(PackReader& reader, const fs::path& manifest) {
  return open(reader, manifest, Options{});
}

std::optional<PackResult<DevelopmentReader>> DevelopmentReader::from_environment(PackReader& reader, const fs::path& manifest) {
  const char* value = std::getenv("KILN_DEVELOPMENT_ENDPOINT");
  if (!value || !*value) return std::nullopt;
  Options options;
  if (std::string_view(value) != "auto") options.endpoint = value;
  return open(reader, manifest, std::move(options));
}

PackResult<std::string> DevelopmentReader::request(std::string_view pass, const Keywords& keywords, std::chrono::milliseconds timeout) {
  return impl_->post(pass, impl_->declared(pass, keywords), timeout);
}

PackResult<SelectedVariant> DevelopmentReader::select_or_wait(std::string_view pass, const Keywords& keywords,
                                                              std::chrono::milliseconds timeout) {
  PackResult<SelectedVariant> selected = impl_->reader->try_select(pass, keywords);
  if (selected || selected.code() != PackError::Code::Stripped) return selected;
  PackResult<std::string> archive = request(pass, keywords, timeout);
  if (!archive) return failed(archive.error());
  PackResult<PackUpdate> update = impl_->reader->poll_update();
  if (!update) return failed(update.error());
  return impl_->reader->try_select(pass, keywords);
}

PackResult<DevelopmentReader::Selection> DevelopmentReader::select_or_nearest(std::string_view pass, const Keywords& keywords) {
  PackResult<SelectedVariant> selected = impl_->reader->try_select(pass, keywords);
  if (selected) return Selection{std::move(*selected), false};
  if (selected.code() != PackError::Code::Stripped) return failed(selected.error());
  const Keywords wanted = impl_->declared(pass, keywords);
  {
    std::lock_guard lock(impl_->mutex);
    auto key = std::make_pair(std::string(pass), wanted);
    if (!impl_->asked.count(key) && impl_->asked.size() < kMaxAsked && impl_->queue.size() < kMaxPending) {
      impl_->asked.insert(key);
      impl_->queue.push_back(std::move(key));
      ++impl_->in_flight;
      impl_->wake.notify_one();
    }
  }
  PackResult<size_t> count = impl_->reader->try_variant_count(pass);
  if (!count) return failed(count.error());
  size_t best = SIZE_MAX, best_distance = SIZE_MAX;
  for (size_t index = 0; index < *count; ++index) {
    PackResult<SelectedVariant> variant = impl_->reader->try_variant(pass, index);
    if (!variant) return failed(variant.error());
    Keywords difference;
    std::set_symmetric_difference(variant->keywords.begin(), variant->keywords.end(), wanted.begin(), wanted.end(),
                                  std::back_inserter(difference));
    if (difference.size() < best_distance) best_distance = difference.size(), best = index;
  }
  if (best == SIZE_MAX) return failed(selected.error());  // a pass without variants: nothing is near
  PackResult<SelectedVariant> nearest = impl_->reader->try_variant(pass, best);
  if (!nearest) return failed(nearest.error());
  return Selection{std::move(*nearest), true};
}

PackResult<PackUpdate> DevelopmentReader::poll_update() noexcept {
  PackResult<PackUpdate> update = impl_->reader->poll_update();
  report_selected();
  return update;
}

void DevelopmentReader::report_selected() noexcept {
  try {
    impl_->report_selected();
  } catch (const std::exception& error) {  // a log that cannot be read back: said by last_error(), tried again later
    try {
      std::lock_guard lock(impl_->mutex);
      impl_->last_error = std::string("development endpoint: cannot report the selected variants: ") + error.what();
    } catch (...) {
    }
  } catch (...) {
  }
}

size_t DevelopmentReader::reported() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->reported.size();
}

size_t DevelopmentReader::pending() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->in_flight;
}

std::string DevelopmentReader::last_error() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->last_error;
}

}  // namespace kiln
