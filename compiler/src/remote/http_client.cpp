// SPDX-License-Identifier: Apache-2.0
#include "remote/http_client.hpp"

#include <curl/curl.h>

#include <algorithm>
#include <cstring>
#include <mutex>
#include <new>
#include <stdexcept>
#include <thread>

namespace kiln {
namespace {

CURL* handle(void* curl) { return static_cast<CURL*>(curl); }

HttpResult::Failure classify(CURLcode code) {
  switch (code) {
    case CURLE_OK: return HttpResult::Failure::None;
    case CURLE_COULDNT_CONNECT:
    case CURLE_COULDNT_RESOLVE_HOST:
    case CURLE_COULDNT_RESOLVE_PROXY:
    case CURLE_SSL_CONNECT_ERROR:
    case CURLE_PEER_FAILED_VERIFICATION:
    case CURLE_SSL_CACERT_BADFILE:
    case CURLE_SSL_CERTPROBLEM:
    case CURLE_UNSUPPORTED_PROTOCOL:
    case CURLE_URL_MALFORMAT:
      return HttpResult::Failure::Connect;
    case CURLE_OPERATION_TIMEDOUT: return HttpResult::Failure::Timeout;
    case CURLE_PARTIAL_FILE:
    case CURLE_RECV_ERROR:
    case CURLE_SEND_ERROR:
    case CURLE_GOT_NOTHING:
    case CURLE_WEIRD_SERVER_REPLY:
    case CURLE_HTTP2:
    case CURLE_HTTP2_STREAM:
      return HttpResult::Failure::Cut;
    case CURLE_FILESIZE_EXCEEDED: return HttpResult::Failure::TooLarge;
    default: return HttpResult::Failure::Other;
  }
}

}  // namespace

void initialize_http() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (curl_global_init(CURL_GLOBAL_DEFAULT) != CURLE_OK) throw std::runtime_error("libcurl failed to initialize");
  });
}

HttpClient::HttpClient(HttpSettings settings) : settings_(std::move(settings)) {
  initialize_http();
  curl_ = curl_easy_init();
  if (!curl_) throw std::runtime_error("libcurl failed to make a handle");
  CURL* c = handle(curl_);
  curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);  // threads: no SIGALRM for timeouts
  curl_easy_setopt(c, CURLOPT_PROTOCOLS_STR, settings_.https_only ? "https" : "http,https");
  curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 0L);  // a redirect is an error status, never a downgrade
  curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT_MS, static_cast<long>(settings_.connect_timeout.count()));
  curl_easy_setopt(c, CURLOPT_TIMEOUT_MS, static_cast<long>(settings_.operation_timeout.count()));
  curl_easy_setopt(c, CURLOPT_LOW_SPEED_LIMIT, defaults::kRemoteLowSpeedBytesPerSecond);
  curl_easy_setopt(c, CURLOPT_LOW_SPEED_TIME, static_cast<long>(defaults::kRemoteLowSpeedTime.count()));
  curl_easy_setopt(c, CURLOPT_SSL_VERIFYPEER, 1L);
  curl_easy_setopt(c, CURLOPT_SSL_VERIFYHOST, 2L);
  if (!settings_.ca_file.empty()) curl_easy_setopt(c, CURLOPT_CAINFO, settings_.ca_file.c_str());
  curl_easy_setopt(c, CURLOPT_USERAGENT, "kiln-remote-cache/1");
  curl_easy_setopt(c, CURLOPT_ERRORBUFFER, error_);
  curl_slist* headers = nullptr;
  // curl waits up to a second for "100 Continue" before sending a large body; nginx and bazel-remote need no such handshake.
  headers = curl_slist_append(headers, "Expect:");
  if (!settings_.bearer_token.empty()) {
    headers = curl_slist_append(headers, ("Authorization: Bearer " + settings_.bearer_token).c_str());
  } else {
    curl_easy_setopt(c, CURLOPT_NETRC, static_cast<long>(CURL_NETRC_OPTIONAL));
    if (!settings_.netrc_file.empty()) curl_easy_setopt(c, CURLOPT_NETRC_FILE, settings_.netrc_file.c_str());
  }
  headers_ = headers;
  curl_easy_setopt(c, CURLOPT_HTTPHEADER, headers);
  curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, +[](char* data, size_t size, size_t count, void* self_pointer) -> size_t {
    auto* self = static_cast<HttpClient*>(self_pointer);
    const size_t bytes = size * count;
    if (!self->download_) return bytes;  // an error page of a HEAD or PUT: not kept
    long status = 0;
    curl_easy_getinfo(handle(self->curl_), CURLINFO_RESPONSE_CODE, &status);
    if (status != 200) return bytes;  // an error page (Apache's 404 page is longer than a small blob): not kept
    if (self->download_->size() + bytes > self->download_limit_) {
      self->over_limit_ = true;
      return 0;  // stops the transfer
    }
    // The body's announced length, within the limit, is allocated once (a bundle of megabytes is not regrown).
    // A body this process cannot hold stops the transfer (an exception must not cross libcurl's C frames): the
    // caller sees Failure::OutOfMemory, a fallback, not a failed build.
    try {
      curl_off_t announced = -1;
      if (self->download_->empty() &&
          curl_easy_getinfo(handle(self->curl_), CURLINFO_CONTENT_LENGTH_DOWNLOAD_T, &announced) == CURLE_OK &&
          announced > 0 && static_cast<uint64_t>(announced) <= self->download_limit_)
        self->download_->reserve(static_cast<size_t>(announced));
      self->download_->append(data, bytes);
    } catch (const std::bad_alloc&) {
      std::string().swap(*self->download_);
      self->out_of_memory_ = true;
      return 0;
    }
    return bytes;
  });
  curl_easy_setopt(c, CURLOPT_WRITEDATA, this);
  curl_easy_setopt(c, CURLOPT_READFUNCTION, +[](char* buffer, size_t size, size_t count, void* self_pointer) -> size_t {
    auto* self = static_cast<HttpClient*>(self_pointer);
    size_t bytes = 0;
    while (self->upload_ && self->upload_part_ < self->upload_->size() && bytes < size * count) {
      const std::string_view part = (*self->upload_)[self->upload_part_];
      const size_t n = std::min(size * count - bytes, part.size() - self->upload_offset_);
      std::memcpy(buffer + bytes, part.data() + self->upload_offset_, n);
      bytes += n;
      self->upload_offset_ += n;
      if (self->upload_offset_ == part.size()) {
        ++self->upload_part_;
        self->upload_offset_ = 0;
      }
    }
    return bytes;
  });
  curl_easy_setopt(c, CURLOPT_READDATA, this);
}

HttpClient::~HttpClient() {
  curl_easy_cleanup(handle(curl_));
  curl_slist_free_all(static_cast<curl_slist*>(headers_));
}

void HttpClient::reset_request() {
  CURL* c = handle(curl_);
  curl_easy_setopt(c, CURLOPT_HTTPGET, 1L);  // also clears NOBODY and UPLOAD
  curl_easy_setopt(c, CURLOPT_CUSTOMREQUEST, nullptr);
  curl_easy_setopt(c, CURLOPT_MAXFILESIZE_LARGE, static_cast<curl_off_t>(0));
  download_ = nullptr;
  download_limit_ = 0;
  over_limit_ = false;
  out_of_memory_ = false;
  upload_ = nullptr;
  upload_part_ = upload_offset_ = 0;
}

void HttpClient::perform(HttpResult& result) {
  CURL* c = handle(curl_);
  error_[0] = 0;
  const CURLcode code = curl_easy_perform(c);
  result.failure = classify(code);
  // libcurl gives one code for both timeouts; its message says which ("Connection timed out after ...", "SSL
  // connection timeout", "Resolving timed out after ...", against "Operation timed out after ...").
  // A transfer under the low-speed limit is the same code again: "Operation too slow. Less than ...".
  const std::string_view message(error_);
  if (code == CURLE_OPERATION_TIMEDOUT && message.starts_with("Operation too slow")) result.failure = HttpResult::Failure::TooSlow;
  else if (code == CURLE_OPERATION_TIMEDOUT && !message.starts_with("Operation timed out"))
    result.failure = HttpResult::Failure::ConnectTimeout;
  if (over_limit_) result.failure = HttpResult::Failure::TooLarge;
  if (out_of_memory_) result.failure = HttpResult::Failure::OutOfMemory;
  if (result.failure == HttpResult::Failure::None) {
    curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &result.status);
  } else {
    result.detail = curl_easy_strerror(code);
    std::string().swap(result.body);
  }
}

template <class Attempt>
HttpResult HttpClient::with_retries(Attempt attempt) {
  auto pause = defaults::kRemoteRetryPause;
  for (int tries = 0;; ++tries) {
    HttpResult result = attempt();
    const bool worth_another = result.failure == HttpResult::Failure::Cut ||
                               (result.failure == HttpResult::Failure::None &&
                                (result.status == 429 || (result.status >= 500 && result.status != 507)));
    if (!worth_another || tries == defaults::kRemoteRetries) return result;
    std::this_thread::sleep_for(pause);
    pause *= 2;
  }
}

HttpResult HttpClient::get(const std::string& url, uint64_t max_bytes) {
  return with_retries([&] {
    reset_request();
    CURL* c = handle(curl_);
    curl_easy_setopt(c, CURLOPT_URL, url.c_str());
    HttpResult result;
    download_ = &result.body;
    download_limit_ = max_bytes;
    perform(result);
    download_ = nullptr;
    if (result.status != 200) result.body.clear();  // an error page is not an entry (nor counted)
    result.bytes = result.body.size();
    return result;
  });
}

HttpResult HttpClient::head(const std::string& url) {
  return with_retries([&] {
    reset_request();
    CURL* c = handle(curl_);
    curl_easy_setopt(c, CURLOPT_URL, url.c_str());
    curl_easy_setopt(c, CURLOPT_NOBODY, 1L);
    HttpResult result;
    perform(result);
    return result;
  });
}

HttpResult HttpClient::put(const std::string& url, std::string_view body) {
  return put(url, std::vector<std::string_view>{body});
}

HttpResult HttpClient::put(const std::string& url, const std::vector<std::string_view>& body) {
  uint64_t size = 0;
  for (std::string_view part : body) size += part.size();
  return with_retries([&] {
    reset_request();
    CURL* c = handle(curl_);
    curl_easy_setopt(c, CURLOPT_URL, url.c_str());
    curl_easy_setopt(c, CURLOPT_UPLOAD, 1L);  // PUT
    curl_easy_setopt(c, CURLOPT_INFILESIZE_LARGE, static_cast<curl_off_t>(size));  // Content-Length, not chunked
    upload_ = &body;
    HttpResult result;
    perform(result);
    if (result.failure == HttpResult::Failure::None) result.bytes = size;
    return result;
  });
}

HttpResult HttpClient::mkcol(const std::string& url) {
  return with_retries([&] {
    reset_request();
    CURL* c = handle(curl_);
    curl_easy_setopt(c, CURLOPT_URL, url.c_str());
    curl_easy_setopt(c, CURLOPT_CUSTOMREQUEST, "MKCOL");  // a GET's shape (no request body); the answer's body is dropped
    HttpResult result;
    perform(result);
    return result;
  });
}

}  // namespace kiln
