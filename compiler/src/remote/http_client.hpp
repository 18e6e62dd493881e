// SPDX-License-Identifier: Apache-2.0
// One kept-alive HTTP(S) connection through libcurl, for the remote cache tier: GET with a size bound, HEAD,
// and PUT with a Content-Length (never chunked: bazel-remote refuses chunked uploads). Not thread-safe: one
// client per thread. TLS is always verified (system CAs or a given CA file), redirects are not followed, and
// an https:// base never talks plain HTTP.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/defaults.hpp"

namespace kiln {

struct HttpSettings {
  std::chrono::milliseconds connect_timeout = defaults::kRemoteConnectTimeout;
  std::chrono::milliseconds operation_timeout = defaults::kRemoteTimeout;
  std::string bearer_token;  // empty: none; never logged
  std::string ca_file;       // empty: the system's CA store
  std::string netrc_file;    // empty: libcurl's default (~/.netrc); basic auth from a matching machine line
  bool https_only = false;   // the base URL is https: refuse anything else
};

struct HttpResult {
  // Connect: no connection (refused, name not resolved, TLS handshake or certificate verification failed).
  // ConnectTimeout: no connection within the connect timeout. Timeout: connected, but the request took longer
  // than the operation timeout. Cut: the transfer ended early (short body, reset, nothing sent).
  // TooLarge: the body is over the caller's bound (the download was stopped there).
  // TooSlow: fewer than defaults::kRemoteLowSpeedBytesPerSecond for defaults::kRemoteLowSpeedTime.
  // OutOfMemory: the body (its announced length, or what arrived) could not be held; the transfer was stopped.
  enum class Failure { None, Connect, ConnectTimeout, Timeout, TooSlow, Cut, TooLarge, OutOfMemory, Other };
  Failure failure = Failure::None;
  long status = 0;     // HTTP status when answered
  std::string body;    // GET
  std::string detail;  // libcurl's description of `failure` (fixed text per error: no timings, no addresses)
  uint64_t bytes = 0;  // body bytes received or sent
};

class HttpClient {
 public:
  explicit HttpClient(HttpSettings settings);
  ~HttpClient();
  HttpClient(const HttpClient&) = delete;
  HttpClient& operator=(const HttpClient&) = delete;

  HttpResult get(const std::string& url, uint64_t max_bytes);
  HttpResult head(const std::string& url);
  HttpResult put(const std::string& url, std::string_view body);
  HttpResult put(const std::string& url, const std::vector<std::string_view>& body);  // the parts, joined
  HttpResult mkcol(const std::string& url);  // WebDAV: make a collection (201; 405 when it exists)

 private:
  void reset_request();
  void perform(HttpResult& result);  // fills `result` (GET: its body is being written)
  // Runs `attempt` (which sets up and performs one request) again after a pause while the result is worth another
  // try: 429 or 5xx other than 507, or a transfer cut short; at most defaults::kRemoteRetries times.
  template <class Attempt>
  HttpResult with_retries(Attempt attempt);

  HttpSettings settings_;
  void* curl_ = nullptr;          // CURL*
  void* headers_ = nullptr;       // curl_slist*: the request headers every request sends
  const std::vector<std::string_view>* upload_ = nullptr;  // PUT: the body's parts
  size_t upload_part_ = 0, upload_offset_ = 0;              // the first byte not yet sent
  std::string* download_ = nullptr;
  uint64_t download_limit_ = 0;
  bool over_limit_ = false;
  bool out_of_memory_ = false;
  char error_[256] = {};  // CURLOPT_ERRORBUFFER
};

// libcurl's global initialization, once per process (thread-safe).
void initialize_http();

}  // namespace kiln
