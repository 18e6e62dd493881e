// SPDX-License-Identifier: Apache-2.0
#include "kiln/result.hpp"
#include "remote/remote_cache.hpp"

#include <curl/curl.h>
#include <openssl/evp.h>
#include <sys/eventfd.h>

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include "common/bytes.hpp"
#include "common/files.hpp"
#include "common/parallel.hpp"
#include "kiln/command_line.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/pack_reader.hpp"
#include "pack/pack_writer.hpp"
#include "common/blob.hpp"

namespace kiln {
namespace {

// A record (the value under /ac/): magic, format, kind, key echo, payload size, payload SHA-256, payload.
constexpr char kRecordMagic[8] = {'K', 'I', 'L', 'N', 'R', 'M', 'T', 'C'};
constexpr uint32_t kRemoteFormat = 1;
constexpr size_t kRecordHeaderSize = 8 + 4 + 4 + 32 + 8 + 32;
enum RecordKind : uint32_t { kResult = 1, kAlias = 2, kPack = 3, kShard = 4, kShardCount = 5 };
// A module's record holds its reflection and messages: kiln's largest is a few KiB; this bounds what a hostile
// server can make kiln download and decode.
constexpr uint64_t kMaxRecordBytes = uint64_t{16} << 20;
constexpr uint32_t kMaxBlobsPerResult = 16;
// Three failures in a row switch the remote off (ccache disables a failing backend for the rest of the run); a
// connection failure or a connect timeout switches it off at once. Only an answered download resets the count:
// a server that answers HEAD and refuses every PUT is switched off after three refused uploads.
constexpr unsigned kErrorsBeforeSwitchingOff = 3;

void put_key(std::string& out, const RemoteKey& key) { out.append(reinterpret_cast<const char*>(key.bytes.data()), 32); }
RemoteKey get_key(std::string_view in, size_t at) {
  RemoteKey key;
  std::memcpy(key.bytes.data(), in.data() + at, 32);
  return key;
}

std::string make_record(uint32_t kind, const RemoteKey& key, std::string_view payload) {
  std::string record(kRecordMagic, 8);
  put32(record, kRemoteFormat);
  put32(record, kind);
  put_key(record, key);
  put64(record, payload.size());
  put_key(record, sha256(payload));
  record += payload;
  return record;
}

// The payload when the record is whole and is the entry asked for; else why not.
Result<std::string_view> check_record(std::string_view record, const RemoteKey& key, uint32_t kind) {
  if (record.size() < kRecordHeaderSize || std::memcmp(record.data(), kRecordMagic, 8) != 0) return failure("not a kiln record");
  if (get32(record, 8) != kRemoteFormat)
    return failure("record format " + std::to_string(get32(record, 8)) + ", kiln reads " + std::to_string(kRemoteFormat));
  if (get32(record, 12) != kind) return failure("record of another kind");
  if (get_key(record, 16) != key) return failure("record of another key");
  if (get64(record, 48) != record.size() - kRecordHeaderSize) return failure("record size does not match its header");
  const std::string_view payload = record.substr(kRecordHeaderSize);
  if (sha256(payload) != get_key(record, 56)) return failure("record checksum does not match");
  return payload;
}

std::vector<uint8_t> bytes_of(std::string_view text) { return std::vector<uint8_t>(text.begin(), text.end()); }

bool is_loopback(const std::string& host) {
  return host == "127.0.0.1" || host == "localhost" || host == "[::1]" || host == "::1";
}

}  // namespace

std::string RemoteKey::hex() const {
  static const char digits[] = "0123456789abcdef";
  std::string out;
  for (unsigned char b : bytes) {
    out.push_back(digits[b >> 4]);
    out.push_back(digits[b & 15]);
  }
  return out;
}

RemoteKey sha256(std::string_view bytes) {
  RemoteKey key;
  unsigned int size = 0;
  if (!EVP_Digest(bytes.data(), bytes.size(), key.bytes.data(), &size, EVP_sha256(), nullptr) || size != 32)
    throw std::runtime_error("OpenSSL's SHA-256 failed");
  return key;
}

RemoteKey sha256(const std::vector<std::string_view>& parts) {
  RemoteKey key;
  unsigned int size = 0;
  const std::unique_ptr<EVP_MD_CTX, void (*)(EVP_MD_CTX*)> context(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  bool ok = context && EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr);
  for (std::string_view part : parts) ok = ok && EVP_DigestUpdate(context.get(), part.data(), part.size());
  if (!ok || !EVP_DigestFinal_ex(context.get(), key.bytes.data(), &size) || size != 32)
    throw std::runtime_error("OpenSSL's SHA-256 failed");
  return key;
}

RemoteKeyHasher::RemoteKeyHasher() : context_(EVP_MD_CTX_new()) {
  if (!context_ || !EVP_DigestInit_ex(static_cast<EVP_MD_CTX*>(context_), EVP_sha256(), nullptr))
    throw std::runtime_error("OpenSSL's SHA-256 failed");
}
RemoteKeyHasher::~RemoteKeyHasher() { EVP_MD_CTX_free(static_cast<EVP_MD_CTX*>(context_)); }

RemoteKeyHasher& RemoteKeyHasher::add(std::string_view field) {
  add(static_cast<uint64_t>(field.size()));
  EVP_DigestUpdate(static_cast<EVP_MD_CTX*>(context_), field.data(), field.size());
  return *this;
}

RemoteKeyHasher& RemoteKeyHasher::add(uint64_t value) {
  unsigned char bytes[8];
  for (int i = 0; i < 8; ++i) bytes[i] = static_cast<unsigned char>(value >> (8 * i));
  EVP_DigestUpdate(static_cast<EVP_MD_CTX*>(context_), bytes, sizeof bytes);
  return *this;
}

RemoteKey RemoteKeyHasher::finish() {
  RemoteKey key;
  unsigned int size = 0;
  if (!EVP_DigestFinal_ex(static_cast<EVP_MD_CTX*>(context_), key.bytes.data(), &size) || size != 32)
    throw std::runtime_error("OpenSSL's SHA-256 failed");
  return key;
}

RemoteCache::RemoteCache(const RemoteCacheOptions& options) : options_(options) {}
RemoteCache::~RemoteCache() = default;

std::unique_ptr<RemoteCache> RemoteCache::open(const RemoteCacheOptions& options, DiagnosticSink& sink) {
  if (options.url.empty()) return nullptr;
  std::unique_ptr<RemoteCache> remote(new RemoteCache(options));
  remote->report_.configured = true;
  if (Result<void> configured = remote->configure(); !configured) {
    remote->switched_off_ = true;
    remote->problem(DiagId::RemoteConfiguration, configured.error().message,
                    options.required || options.upload ? "the build stops before compiling anything"
                                                       : "the build goes on without the remote cache");
    remote->report_problems(sink);
  }
  return remote;
}

Result<void> RemoteCache::configure() {
  initialize_http();
  CURLU* url = curl_url();
  if (!url) return failure("libcurl failed to parse the remote cache URL");
  std::unique_ptr<CURLU, void (*)(CURLU*)> owned(url, curl_url_cleanup);
  // The URL itself is not echoed: it can carry a password.
  if (curl_url_set(url, CURLUPART_URL, options_.url.c_str(), 0) != CURLUE_OK) return failure("the remote cache URL is not a URL");
  char* part = nullptr;
  std::string scheme, host;
  if (curl_url_get(url, CURLUPART_SCHEME, &part, 0) == CURLUE_OK) scheme = part;
  curl_free(part);
  part = nullptr;
  if (curl_url_get(url, CURLUPART_HOST, &part, 0) == CURLUE_OK) host = part;
  curl_free(part);
  part = nullptr;
  if (scheme != "http" && scheme != "https") return failure("the remote cache URL must start with http:// or https://");
  curl_url_set(url, CURLUPART_QUERY, nullptr, 0);
  curl_url_set(url, CURLUPART_FRAGMENT, nullptr, 0);
  if (curl_url_get(url, CURLUPART_URL, &part, 0) == CURLUE_OK) base_ = part;
  curl_free(part);
  part = nullptr;
  curl_url_set(url, CURLUPART_USER, nullptr, 0);
  curl_url_set(url, CURLUPART_PASSWORD, nullptr, 0);
  if (curl_url_get(url, CURLUPART_URL, &part, 0) == CURLUE_OK) display_ = part;
  curl_free(part);
  while (!base_.empty() && base_.back() == '/') base_.pop_back();
  while (!display_.empty() && display_.back() == '/') display_.pop_back();
  if (!options_.instance.empty()) {
    const std::string& instance = options_.instance;
    const bool safe = std::all_of(instance.begin(), instance.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' || c == '/';
    });
    if (!safe || instance.find("..") != std::string::npos || instance.front() == '/' || instance.back() == '/')
      return failure("the remote cache instance name '" + instance + "' must be path segments of letters, digits, '-', '_' and '.'");
    base_ += "/" + instance;
  }

  http_.connect_timeout = options_.connect_timeout;
  http_.operation_timeout = options_.operation_timeout;
  http_.ca_file = options_.ca_file.string();
  http_.netrc_file = options_.netrc_file.string();
  http_.https_only = scheme == "https";
  // A token is one header value: a CR or LF in it would end the Authorization header and start one of the
  // token's choosing. The variable is held to the token file's rule.
  auto is_one_token = [](const std::string& token) {
    return !token.empty() && std::all_of(token.begin(), token.end(), [](char c) { return c > ' ' && c < 127; });
  };
  http_.bearer_token = options_.bearer_token;
  if (!http_.bearer_token.empty() && !is_one_token(http_.bearer_token)) {
    http_.bearer_token.clear();
    return failure("the remote cache token (KILN_REMOTE_TOKEN) is not one token: it holds a space, a line break or another "
           "character outside printable ASCII");
  }
  if (http_.bearer_token.empty() && !options_.token_file.empty()) {
    ReadLimits limits{4096};
    DiagnosticSink ignored;
    // A regular file of at most 4 KiB (read_text_file refuses FIFOs and devices); its own diagnostics would
    // quote the file, so they are dropped.
    auto text = read_text_file(options_.token_file, limits, ignored, SourceLocation{});
    if (!text) return failure("the token file '" + options_.token_file.string() + "' cannot be read (or is over 4 KiB)");
    std::string token = *text;
    while (!token.empty() && std::isspace(static_cast<unsigned char>(token.back()))) token.pop_back();
    if (!is_one_token(token)) return failure("the token file '" + options_.token_file.string() + "' does not hold one token");
    http_.bearer_token = token;
  }
  // A token sent in clear text is a token given away; loopback is the exception tests and local proxies need.
  if (!http_.bearer_token.empty() && scheme == "http" && !is_loopback(host))
    return failure("refusing to send the remote cache token over plain HTTP to '" + host + "': use https://");
  return {};
}

std::unique_ptr<HttpClient> RemoteCache::take_client() {
  {
    std::lock_guard lock(mutex_);
    if (!idle_.empty()) {
      std::unique_ptr<HttpClient> client = std::move(idle_.back());
      idle_.pop_back();
      return client;
    }
  }
  return std::make_unique<HttpClient>(http_);
}

void RemoteCache::give_back(std::unique_ptr<HttpClient> client) {
  std::lock_guard lock(mutex_);
  idle_.push_back(std::move(client));
}

std::string RemoteCache::url(std::string_view kind, const RemoteKey& key) const {
  return base_ + "/" + std::string(kind) + "/" + key.hex();
}

void RemoteCache::start_key(RemoteKeyHasher& hasher, std::string_view kind) const {
  hasher.add("kiln remote cache key").add(uint64_t{kRemoteFormat}).add(options_.key_namespace).add(kind);
}

void RemoteCache::problem(DiagId id, const std::string& message, const std::string& note) {
  std::lock_guard lock(mutex_);
  ++report_.errors;
  problems_[id].emplace_back(message, note);
  // With --remote-required the first problem ends the remote's part in the build (the build fails, and fails now).
  if (options_.required || id == DiagId::RemoteUnreachable || ++consecutive_errors_ >= kErrorsBeforeSwitchingOff)
    switched_off_ = true;
}

void RemoteCache::success() {
  std::lock_guard lock(mutex_);
  consecutive_errors_ = 0;
}

bool RemoteCache::answered(const HttpResult& result, const std::string& what) {
  {
    std::lock_guard lock(mutex_);
    report_.bytes_down += what == "download" ? result.bytes : 0;
  }
  switch (result.failure) {
    case HttpResult::Failure::None: return true;
    case HttpResult::Failure::Connect:
      problem(DiagId::RemoteUnreachable, "cannot reach the remote cache: " + result.detail);
      return false;
    case HttpResult::Failure::ConnectTimeout:
      problem(DiagId::RemoteTimeout, "could not connect to the remote cache within the connect timeout (" +
                                         std::to_string(options_.connect_timeout.count()) + " ms)");
      switched_off_ = true;  // like a refused connection: every other request would wait as long
      return false;
    case HttpResult::Failure::Timeout:
      problem(DiagId::RemoteTimeout, "no answer from the remote cache within the request timeout (" +
                                         std::to_string(options_.operation_timeout.count()) + " ms)");
      switched_off_ = true;  // every other request would wait as long
      return false;
    case HttpResult::Failure::TooSlow:
      problem(DiagId::RemoteTimeout, "the remote cache sent less than " + std::to_string(defaults::kRemoteLowSpeedBytesPerSecond) +
                                         " bytes a second for " + std::to_string(defaults::kRemoteLowSpeedTime.count()) +
                                         " s: the transfer was cut off");
      switched_off_ = true;
      return false;
    case HttpResult::Failure::TooLarge:
      problem(DiagId::RemoteEntryRejected, "a remote cache " + what + " was over its size limit");
      return false;
    case HttpResult::Failure::OutOfMemory:
      problem(DiagId::RemoteEntryRejected, "a remote cache " + what + " was larger than this process could hold in memory");
      return false;
    case HttpResult::Failure::Cut:
    case HttpResult::Failure::Other:
      problem(DiagId::RemoteTransferCut, "a " + what + " from the remote cache was cut short: " + result.detail);
      return false;
  }
  return false;
}

Result<std::optional<std::string>> RemoteCache::get_record(HttpClient& client, const RemoteKey& key, uint32_t kind) {
  if (switched_off_) return failure("the remote cache is switched off");
  HttpResult result = client.get(url("ac", key), kMaxRecordBytes);
  if (!answered(result, "download")) return failure("the download failed: " + result.detail);
  if (result.status == 404) {
    success();
    return std::optional<std::string>();
  }
  if (result.status != 200) {
    const std::string message = "the remote cache answered a download with HTTP " + std::to_string(result.status);
    problem(DiagId::RemoteServerError, message);
    return failure(message);
  }
  success();
  Result<std::string_view> checked = check_record(result.body, key, kind);
  if (!checked) {
    const std::string message = "a remote cache entry failed verification: " + checked.error().message;
    problem(DiagId::RemoteEntryRejected, message, "at ac/" + key.hex());
    return failure(message);
  }
  return std::optional<std::string>(std::string(*checked));
}

std::optional<RemoteFetched> RemoteCache::fetch_one(HttpClient& client, const RemoteKey& key) {
  Result<std::optional<std::string>> alias_record = get_record(client, key, kAlias);
  if (!alias_record || !*alias_record) return std::nullopt;
  const std::string& alias = **alias_record;
  RemoteFetched fetched;
  auto rejected = [&](const std::string& why, const std::string& where) -> std::optional<RemoteFetched> {
    problem(DiagId::RemoteEntryRejected, "a remote cache entry failed verification: " + why, "at " + where);
    return std::nullopt;
  };
  if (alias.size() < 48) return rejected("alias record too short", "ac/" + key.hex());
  const RemoteKey module = get_key(alias, 0);
  fetched.module = Hash128{get64(alias, 32), get64(alias, 40)};
  // From here, a miss means the module's entry is missing or damaged: an uploading build puts it again whole,
  // whatever a HEAD request says (upload_module).
  struct MarkUnlessFetched {
    RemoteCache& cache;
    const RemoteKey& key;
    bool fetched = false;
    ~MarkUnlessFetched() {
      if (fetched) return;
      std::lock_guard lock(cache.mutex_);
      cache.damaged_.insert(key);
    }
  } mark{*this, module};
  try {
    JobOutput front = decode_output(bytes_of(std::string_view(alias).substr(48)));
    if (!front.ok || !front.blobs.empty()) return rejected("alias record does not decode", "ac/" + key.hex());
    fetched.front_messages = std::move(front.messages);
  } catch (const std::exception&) {
    return rejected("alias record does not decode", "ac/" + key.hex());
  }

  Result<std::optional<std::string>> result_record = get_record(client, module, kResult);
  if (!result_record) return std::nullopt;
  if (!*result_record) {  // evicted, or an upload cut short: a plain miss (an uploading build puts the entry back)
    std::lock_guard lock(mutex_);
    ++report_.incomplete;
    return std::nullopt;
  }
  const std::string& result = **result_record;
  if (result.size() < 4 || get32(result, 0) > kMaxBlobsPerResult) return rejected("result record malformed", "ac/" + module.hex());
  const uint32_t count = get32(result, 0);
  constexpr size_t kBlobEntry = 4 + 32 + 8;
  if (result.size() < 4 + count * kBlobEntry) return rejected("result record malformed", "ac/" + module.hex());
  try {
    fetched.module_output = decode_output(bytes_of(std::string_view(result).substr(4 + count * kBlobEntry)));
  } catch (const std::exception&) {
    return rejected("result record does not decode", "ac/" + module.hex());
  }
  JobOutput& output = fetched.module_output;
  if (!output.ok || output.blobs.size() != count) return rejected("result record malformed", "ac/" + module.hex());
  BlobScratch scratch;
  for (uint32_t i = 0; i < count; ++i) {
    const size_t at = 4 + i * kBlobEntry;
    const auto target = static_cast<Target>(get32(result, at));
    const RemoteKey digest = get_key(result, at + 4);
    const uint64_t size = get64(result, at + 36);
    auto blob = output.blobs.find(target);
    if (blob == output.blobs.end() || size > kMaxBlobBytes || blob->second.raw_size > kMaxBlobBytes || size > blob->second.raw_size)
      return rejected("result record malformed", "ac/" + module.hex());
    std::optional<std::string> body = get_blob(client, digest, size);
    if (!body) return std::nullopt;
    PackedBlob& packed = blob->second;
    packed.stored = std::move(*body);
    // The record's sizes and checksums are the server's word too: the blob must unpack to them.
    if (!blob_verifies(packed, scratch))
      return rejected("a blob does not unpack to the record's size, checksum and hash", "cas/" + digest.hex());
  }
  mark.fetched = true;
  return fetched;
}

std::optional<RemoteFetched> RemoteCache::fetch_counted(const RemoteKey& source_key) {
  std::optional<RemoteFetched> found;
  if (!switched_off_) {
    std::unique_ptr<HttpClient> client = take_client();
    found = fetch_one(*client, source_key);
    give_back(std::move(client));
  }
  std::lock_guard lock(mutex_);
  ++(found ? report_.hits : report_.misses);
  return found;
}

std::vector<std::optional<RemoteFetched>> RemoteCache::fetch(const std::vector<RemoteKey>& source_keys) {
  std::vector<std::optional<RemoteFetched>> found(source_keys.size());
  parallel_for(source_keys.size(), std::max(1u, options_.parallel_transfers),
               [&](size_t i) { found[i] = fetch_counted(source_keys[i]); });
  return found;
}

RemoteLookups::RemoteLookups(RemoteCache& remote) : remote_(remote) {
  ready_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (ready_fd_ < 0) throw std::system_error(errno, std::generic_category(), "eventfd");
}

RemoteLookups::~RemoteLookups() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  queued_.notify_all();
  for (std::thread& thread : threads_) thread.join();
  ::close(ready_fd_);
}

void RemoteLookups::submit(size_t tag, const RemoteKey& key) {
  {
    std::lock_guard lock(mutex_);
    queue_.emplace_back(tag, key);
    ++outstanding_;
    if (threads_.size() < std::max(1u, remote_.options_.parallel_transfers)) threads_.emplace_back([this] { work(); });
  }
  queued_.notify_one();
}

void RemoteLookups::work() {
  for (;;) {
    std::pair<size_t, RemoteKey> next;
    {
      std::unique_lock lock(mutex_);
      queued_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      next = queue_.front();
      queue_.pop_front();
    }
    std::optional<RemoteFetched> found = remote_.fetch_counted(next.second);
    {
      std::lock_guard lock(mutex_);
      done_.emplace_back(next.first, std::move(found));
    }
    finished_.notify_all();
    const uint64_t one = 1;
    [[maybe_unused]] ssize_t written = ::write(ready_fd_, &one, sizeof one);
  }
}

std::vector<std::pair<size_t, std::optional<RemoteFetched>>> RemoteLookups::take() {
  uint64_t count = 0;
  [[maybe_unused]] ssize_t got = ::read(ready_fd_, &count, sizeof count);  // before the swap: a later result wakes again
  std::lock_guard lock(mutex_);
  std::vector<std::pair<size_t, std::optional<RemoteFetched>>> taken;
  taken.swap(done_);
  outstanding_ -= taken.size();
  return taken;
}

void RemoteLookups::wait() {
  std::unique_lock lock(mutex_);
  finished_.wait(lock, [&] { return !done_.empty() || outstanding_ == 0; });
}

size_t RemoteLookups::outstanding() const {
  std::lock_guard lock(mutex_);
  return outstanding_;
}

// A WebDAV server that does not make the collections a PUT needs (Apache mod_dav: 409 Conflict) gets them with
// MKCOL, parents first, no higher than the URL's first path segment; 405 means the collection is there (another
// upload made it).
bool RemoteCache::make_collection(HttpClient& client, const std::string& collection, int levels) {
  const size_t path_start = collection.find('/', collection.find("://") + 3);
  HttpResult made = client.mkcol(collection + "/");
  if (!answered(made, "upload")) return false;
  if (made.status == 201 || made.status == 405) return true;
  const size_t parent_end = collection.rfind('/');
  if (made.status != 409 || levels == 0 || path_start == std::string::npos || parent_end <= path_start) return false;
  if (!make_collection(client, collection.substr(0, parent_end), levels - 1)) return false;
  made = client.mkcol(collection + "/");
  return answered(made, "upload") && (made.status == 201 || made.status == 405);
}

bool RemoteCache::put(HttpClient& client, const std::string& target, std::string_view body) {
  return put(client, target, std::vector<std::string_view>{body});
}

bool RemoteCache::put(HttpClient& client, const std::string& target, const std::vector<std::string_view>& body) {
  if (switched_off_) return false;
  HttpResult result = client.put(target, body);
  if (!answered(result, "upload")) return false;
  if (result.status == 409 && make_collection(client, target.substr(0, target.rfind('/')), 4)) {
    result = client.put(target, body);
    if (!answered(result, "upload")) return false;
  }
  if (result.status < 200 || result.status > 299) {
    problem(DiagId::RemoteUploadRefused, "the remote cache refused an upload with HTTP " + std::to_string(result.status));
    return false;
  }
  success();
  std::lock_guard lock(mutex_);
  for (std::string_view part : body) report_.bytes_up += part.size();
  return true;
}

// A module whose record is on the server is not sent again if its blobs are there too (HEAD requests); one this build
// found missing or damaged (fetch_one), or whose blobs are gone, is put again whole: blobs, then the record.
bool RemoteCache::upload_module(HttpClient& client, const ModuleUpload& module) {
  if (switched_off_) return false;
  bool damaged = false;
  {
    std::lock_guard lock(mutex_);
    damaged = damaged_.count(module.key) > 0;
  }
  if (!damaged) {
    HttpResult there = client.head(url("ac", module.key));
    if (!answered(there, "request")) return false;
    if (there.status == 200) {
      bool whole = true;
      for (const auto& entry : module.output->blobs) {
        HttpResult blob = client.head(url("cas", sha256(entry.second.stored)));
        if (!answered(blob, "request")) return false;
        whole = whole && blob.status == 200;
      }
      if (whole) return true;  // another build uploaded it whole
      damaged = true;
    }
  }
  std::string payload;
  put32(payload, static_cast<uint32_t>(module.output->blobs.size()));
  JobOutput described = *module.output;
  for (auto& [target, blob] : described.blobs) {
    const RemoteKey digest = sha256(blob.stored);
    put32(payload, static_cast<uint32_t>(target));
    put_key(payload, digest);
    put64(payload, blob.stored.size());
    if (!put(client, url("cas", digest), blob.stored)) return false;
    std::lock_guard lock(mutex_);
    ++report_.blobs_uploaded;
    blob.stored.clear();  // the record names the blob; it does not carry it
  }
  const std::vector<uint8_t> encoded = encode_output(described);
  payload.append(reinterpret_cast<const char*>(encoded.data()), encoded.size());
  if (!put(client, url("ac", module.key), make_record(kResult, module.key, payload))) return false;
  std::lock_guard lock(mutex_);
  ++report_.uploads;
  if (damaged) ++report_.repaired;
  return true;
}

void RemoteCache::upload(const std::vector<ModuleUpload>& modules, const std::vector<AliasUpload>& aliases) {
  if (switched_off_ || !options_.upload) return;
  const unsigned threads = std::max(1u, options_.parallel_transfers);
  std::vector<char> module_there(modules.size(), 0);
  parallel_for(modules.size(), threads, [&](size_t m) {
    if (switched_off_) return;
    std::unique_ptr<HttpClient> client = take_client();
    module_there[m] = upload_module(*client, modules[m]);
    give_back(std::move(client));
  });
  // Aliases last, and only to results now on the server: a reader never follows one to nothing.
  parallel_for(aliases.size(), threads, [&](size_t a) {
    const AliasUpload& alias = aliases[a];
    if (switched_off_ || !module_there[alias.module]) return;
    std::string payload;
    put_key(payload, modules[alias.module].key);
    put64(payload, alias.module_local.low);
    put64(payload, alias.module_local.high);
    JobOutput front;
    front.ok = true;
    front.messages = *alias.messages;
    const std::vector<uint8_t> encoded = encode_output(front);
    payload.append(reinterpret_cast<const char*>(encoded.data()), encoded.size());
    std::unique_ptr<HttpClient> client = take_client();
    if (put(*client, url("ac", alias.key), make_record(kAlias, alias.key, payload))) {
      std::lock_guard lock(mutex_);
      ++report_.uploads;
    }
    give_back(std::move(client));
  });
}

std::optional<std::string> RemoteCache::get_blob(HttpClient& client, const RemoteKey& digest, uint64_t size) {
  if (switched_off_) return std::nullopt;
  HttpResult got = client.get(url("cas", digest), size);
  if (!answered(got, "download")) return std::nullopt;
  auto rejected = [&](const std::string& why) -> std::optional<std::string> {
    problem(DiagId::RemoteEntryRejected, "a remote cache entry failed verification: " + why, "at cas/" + digest.hex());
    return std::nullopt;
  };
  if (got.status == 404) {  // evicted, or an upload cut short: a plain miss (an uploading build puts it back)
    success();
    std::lock_guard lock(mutex_);
    ++report_.incomplete;
    return std::nullopt;
  }
  if (got.status != 200) {
    problem(DiagId::RemoteServerError, "the remote cache answered a download with HTTP " + std::to_string(got.status));
    return std::nullopt;
  }
  success();
  if (got.body.size() != size) return rejected("a blob has the wrong size");
  if (sha256(got.body) != digest) return rejected("a blob's SHA-256 does not match its name");
  return std::move(got.body);
}

std::optional<std::string> RemoteCache::fetch_pack(const RemoteKey& key, const std::filesystem::path& directory,
                                                   const std::string& pack_name) {
  if (switched_off_) return std::nullopt;
  std::unique_ptr<HttpClient> client = take_client();
  Result<std::optional<std::string>> pack_record = get_record(*client, key, kPack);
  auto rejected = [&](const std::string& why) -> std::optional<std::string> {
    problem(DiagId::RemoteEntryRejected, "a remote cache entry failed verification: " + why, "at ac/" + key.hex());
    return std::nullopt;
  };
  std::optional<std::string> manifest, archive;
  std::string archive_file;
  if (pack_record && *pack_record) {
    const std::string& record = **pack_record;
    // Payload: archive file name (length, bytes), then manifest and archive each as SHA-256 and size.
    if (record.size() < 4 || record.size() != 4 + uint64_t{get32(record, 0)} + 2 * 40) return rejected("pack record malformed");
    archive_file = record.substr(4, get32(record, 0));
    const size_t at = 4 + archive_file.size();
    const uint64_t manifest_size = get64(record, at + 32), archive_size = get64(record, at + 72);
    if (!is_archive_file_name(archive_file, pack_name) || manifest_size > kMaxManifestBytes || archive_size > kMaxArchiveBytes)
      return rejected("pack record malformed");
    manifest = get_blob(*client, get_key(record, at), manifest_size);
    if (manifest) archive = get_blob(*client, get_key(record, at + 40), archive_size);
  }
  give_back(std::move(client));
  if (!manifest || !archive) return std::nullopt;

  // Opened whole by the reader (checksums, sizes, structure) in a scratch directory before it replaces anything.
  const std::string scratch = make_scratch_directory(directory, ".kiln-remote-").string();
  if (scratch.empty()) return std::nullopt;
  std::error_code ec;
  bool good = write_output_file(std::filesystem::path(scratch) / archive_file, *archive).has_value() &&
              write_output_file(manifest_path(scratch, pack_name), *manifest).has_value();
  try {
    good = good && PackReader::open(manifest_path(scratch, pack_name), PackReader::Check::Full).name() == pack_name;
  } catch (const PackError& error) {
    std::filesystem::remove_all(scratch, ec);
    return rejected(std::string("the pack does not open: ") + error.what());
  }
  // Same switch as a build: the archive under its own name (already there: the same content), then the manifest's
  // rename.
  if (good && !std::filesystem::exists(directory / archive_file, ec))
    std::filesystem::rename(std::filesystem::path(scratch) / archive_file, directory / archive_file, ec);
  // Only a manifest kiln wrote is replaced: a link or anything else there is left for the pack writer to refuse.
  std::error_code absent;  // not found is no error here
  const std::filesystem::file_status there = std::filesystem::symlink_status(manifest_path(directory, pack_name), absent);
  good = good && (there.type() == std::filesystem::file_type::not_found || there.type() == std::filesystem::file_type::regular);
  if (good && !ec) std::filesystem::rename(manifest_path(scratch, pack_name), manifest_path(directory, pack_name), ec);
  std::filesystem::remove_all(scratch, ec);
  if (!good || !std::filesystem::exists(manifest_path(directory, pack_name))) return std::nullopt;
  std::lock_guard lock(mutex_);
  report_.pack_fetched = true;
  return archive_file;
}

void RemoteCache::upload_pack(const RemoteKey& key, const std::string& archive_file,
                              const std::vector<std::string_view>& archive, std::string_view manifest) {
  if (switched_off_ || !options_.upload) return;
  std::unique_ptr<HttpClient> client = take_client();
  const RemoteKey manifest_digest = sha256(manifest), archive_digest = sha256(archive);
  std::string payload;
  put32(payload, static_cast<uint32_t>(archive_file.size()));
  payload += archive_file;
  put_key(payload, manifest_digest);
  put64(payload, manifest.size());
  put_key(payload, archive_digest);
  uint64_t archive_size = 0;
  for (std::string_view part : archive) archive_size += part.size();
  put64(payload, archive_size);
  if (put(*client, url("cas", archive_digest), archive) && put(*client, url("cas", manifest_digest), manifest) &&
      put(*client, url("ac", key), make_record(kPack, key, payload))) {
    std::lock_guard lock(mutex_);
    ++report_.uploads;
    report_.blobs_uploaded += 2;
  }
  give_back(std::move(client));
}

bool RemoteCache::upload_shard(const RemoteKey& key, std::string_view bundle) {
  if (switched_off_ || !options_.upload) return false;
  std::unique_ptr<HttpClient> client = take_client();
  const RemoteKey digest = sha256(bundle);
  std::string payload;
  put_key(payload, digest);
  put64(payload, bundle.size());
  const bool done = put(*client, url("cas", digest), bundle) && put(*client, url("ac", key), make_record(kShard, key, payload));
  give_back(std::move(client));
  if (done) {
    std::lock_guard lock(mutex_);
    ++report_.uploads;
    ++report_.blobs_uploaded;
  }
  return done;
}

bool RemoteCache::upload_shard_count(const RemoteKey& key, uint32_t count) {
  if (switched_off_ || !options_.upload) return false;
  std::unique_ptr<HttpClient> client = take_client();
  std::string payload;
  put32(payload, count);
  const bool done = put(*client, url("ac", key), make_record(kShardCount, key, payload));
  give_back(std::move(client));
  if (done) {
    std::lock_guard lock(mutex_);
    ++report_.uploads;
  }
  return done;
}

std::optional<uint32_t> RemoteCache::fetch_shard_count(const RemoteKey& key) {
  std::unique_ptr<HttpClient> client = take_client();
  Result<std::optional<std::string>> record = get_record(*client, key, kShardCount);
  give_back(std::move(client));
  if (!record || !*record) return std::nullopt;
  if ((*record)->size() != 4 || get32(**record, 0) < 2 || get32(**record, 0) > kMaxShardCount) {
    problem(DiagId::RemoteEntryRejected, "a remote cache entry failed verification: shard count record malformed", "at ac/" + key.hex());
    return std::nullopt;
  }
  return get32(**record, 0);
}

std::vector<bool> RemoteCache::have_records(const std::vector<RemoteKey>& keys) {
  std::vector<char> there(keys.size(), 0);
  parallel_for(keys.size(), std::max(1u, options_.parallel_transfers), [&](size_t k) {
    if (switched_off_) return;
    std::unique_ptr<HttpClient> client = take_client();
    HttpResult result = client->head(url("ac", keys[k]));
    there[k] = answered(result, "request") && result.status == 200;
    give_back(std::move(client));
  });
  return std::vector<bool>(there.begin(), there.end());
}

void RemoteCache::fetch_shards(const std::vector<RemoteKey>& keys, const std::function<void(size_t, std::string&&)>& use) {
  // The records first: the sizes they give are the server's word, and their sum is bounded (by what one pack's
  // archive may be) before anything is downloaded.
  std::vector<std::optional<std::pair<RemoteKey, uint64_t>>> named(keys.size());
  const unsigned threads = std::max(1u, options_.parallel_transfers);
  parallel_for(keys.size(), threads, [&](size_t k) {
    if (switched_off_) return;
    std::unique_ptr<HttpClient> client = take_client();
    Result<std::optional<std::string>> record = get_record(*client, keys[k], kShard);
    if (record && *record) {
      if ((*record)->size() != 40 || get64(**record, 32) > kMaxArchiveBytes)
        problem(DiagId::RemoteEntryRejected, "a remote cache entry failed verification: shard record malformed", "at ac/" + keys[k].hex());
      else
        named[k] = std::make_pair(get_key(**record, 0), get64(**record, 32));
    }
    give_back(std::move(client));
  });
  uint64_t total = 0;
  for (const auto& bundle : named) total += bundle ? bundle->second : 0;
  if (total > kMaxArchiveBytes) {
    problem(DiagId::RemoteEntryRejected,
            "a remote cache entry failed verification: the shards' bundles would be " + std::to_string(total) +
                " bytes, more than a pack's archive may be (" + std::to_string(kMaxArchiveBytes) + ")",
            "at the shard records of this build's inputs");
    return;
  }
  // Batches in order of the keys: [first, last) holds at most kShardBatchBytes, or one bundle larger than that.
  for (size_t first = 0; first < keys.size() && !switched_off_;) {
    auto size = [&](size_t k) { return named[k] ? named[k]->second : 0; };
    size_t last = first + 1;
    for (uint64_t batch = size(first); last < keys.size() && batch + size(last) <= kShardBatchBytes; ++last)
      batch += size(last);
    std::vector<std::optional<std::string>> bundles(last - first);
    parallel_for(last - first, threads, [&](size_t i) {
      if (switched_off_ || !named[first + i]) return;
      std::unique_ptr<HttpClient> client = take_client();
      bundles[i] = get_blob(*client, named[first + i]->first, named[first + i]->second);
      give_back(std::move(client));
    });
    for (size_t i = 0; i < bundles.size(); ++i) {
      if (!bundles[i]) continue;
      std::string bundle = std::move(*bundles[i]);
      bundles[i].reset();
      use(first + i, std::move(bundle));
    }
    first = last;
  }
}

void RemoteCache::entry_rejected(const std::string& why, const std::string& where) {
  problem(DiagId::RemoteEntryRejected, "a remote cache entry failed verification: " + why, "at " + where);
}

void RemoteCache::count_shard_bundles(size_t bundles, size_t sources) {
  std::lock_guard lock(mutex_);
  report_.shard_bundles += bundles;
  report_.shard_sources += sources;
}

void RemoteCache::report_problems(DiagnosticSink& sink) {
  std::lock_guard lock(mutex_);
  for (auto& [id, seen] : problems_) {
    if (seen.empty() || reported_[id]) continue;
    reported_[id] = true;
    // The first in order, not in time: the text does not depend on which request failed first.
    const auto& [message, note] = *std::min_element(seen.begin(), seen.end());
    Diagnostic d;
    d.id = id;
    // Settings that cannot be used are an error when the build needs the remote: --remote-required, or an upload
    // asked for (a CI job that was to warm the cache would otherwise run cold and upload nothing, silently).
    const bool needed = options_.required || (id == DiagId::RemoteConfiguration && options_.upload);
    d.severity = needed ? Severity::Error : Severity::Warning;
    d.location = SourceLocation{display_.empty() ? std::string("remote cache") : display_, 0, 0};
    d.message = message;
    if (!note.empty()) d.notes.push_back(note);
    if (switched_off_ && id != DiagId::RemoteConfiguration) d.notes.push_back("the remote cache is off for the rest of this build");
    if (!needed) d.notes.push_back("a remote cache problem never fails a build; --remote-required makes it an error");
    else if (!options_.required) d.notes.push_back("--remote-upload was asked for, and nothing could be uploaded");
    sink.report(std::move(d));
  }
}

RemoteReport RemoteCache::report() const {
  std::lock_guard lock(mutex_);
  RemoteReport out = report_;
  out.switched_off = switched_off_;
  return out;
}

}  // namespace kiln
