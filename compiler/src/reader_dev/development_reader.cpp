#include "kiln/development_reader.hpp"

#include <arpa/inet.h>
#include <curl/curl.h>

#include <algorithm>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <iterator>
#include <mutex>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "kiln/bounded_json.hpp"

namespace kiln {
namespace {

namespace fs = std::filesystem;
using Keywords = std::vector<std::string>;

// The protocol's bounds (kiln/watch.hpp, development::; the compiler's header, not the reader's, so repeated here).
constexpr size_t kMaxAnswerBytes = 64 * 1024;
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

  ~Impl() {
    {
      std::lock_guard lock(mutex);
      stopping = true;
    }
    wake.notify_all();
    if (thread.joinable()) thread.join();
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

  // One POST /v1/variant; the answer checked before anything in it is used.
  PackResult<std::string> post(std::string_view pass, const Keywords& keywords, std::chrono::milliseconds timeout) const {
    PackResult<std::string> where = endpoint();
    if (!where) return where;
    static std::once_flag initialized;
    std::call_once(initialized, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
    std::unique_ptr<CURL, void (*)(CURL*)> curl(curl_easy_init(), curl_easy_cleanup);
    if (!curl) return failed(io_error("curl_easy_init failed"));
    const std::string url = "http://" + *where + "/v1/variant";
    const std::string body = nlohmann::json{{"pass", pass}, {"keywords", keywords}}.dump();
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
    if (!json.contains("archive") || !json["archive"].is_string() || !is_archive_name(json["archive"].get<std::string>()))
      return failed(io_error("the answer names no archive"));
    return json["archive"].get<std::string>();
  }

  void start_thread() {
    thread = std::thread([this] {
      std::unique_lock lock(mutex);
      for (;;) {
        wake.wait(lock, [&] { return stopping || !queue.empty(); });
        if (stopping) return;
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

size_t DevelopmentReader::pending() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->in_flight;
}

std::string DevelopmentReader::last_error() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->last_error;
}

}  // namespace kiln
