// SPDX-License-Identifier: Apache-2.0
// The development endpoint of kiln watch (docs/development-loop.md, "On-demand variants"): libmicrohttpd on a
// loopback address, run from watch's own poll() loop (its epoll descriptor and timeout join watch's), so that one
// thread serves requests, inotify and signals without a polling sleep. Everything a client sends is untrusted
// (docs/threat-model.md): the method, the path, the headers (bounded by the connection's memory limit), the body
// (bounded before it is kept) and the JSON in it are checked before the handler sees a request.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/result.hpp"
#include "kiln/watch.hpp"
#include "watch/development_protocol.hpp"

namespace kiln::development {

class DevelopmentServer {
 public:
  // What watch does with each valid body: a variant asked for (kVariantPath), a reader's report (kSelectedPath).
  // A variant handler with no answer yet (kiln watch during its full-pack build) holds the request: its connection
  // is suspended, counted in held(), until release_held(); the run() after that asks the handler again.
  struct Handlers {
    std::function<std::optional<Answer>(const VariantRequest&)> variant;
    std::function<Answer(const SelectedReport&)> selected;
  };
  // Listens on `endpoint` (port 0: any). The error says why it cannot.
  static Result<std::unique_ptr<DevelopmentServer>> start(const LoopbackEndpoint& endpoint, Handlers handlers);
  ~DevelopmentServer();
  DevelopmentServer(const DevelopmentServer&) = delete;
  DevelopmentServer& operator=(const DevelopmentServer&) = delete;

  LoopbackEndpoint endpoint() const { return endpoint_; }  // with the port it listens on
  int fd() const;               // readable when run() has work
  int timeout_ms() const;       // when run() must be called even if fd() stays quiet (a connection's timeout); -1: never
  void run();                   // serves what is ready; never blocks but in the handler
  size_t in_flight() const { return in_flight_; }  // connections with a request not yet answered and sent
  size_t held() const { return held_.size(); }
  void release_held();

  // For libmicrohttpd's callbacks.
  std::optional<Answer> handle(const VariantRequest& request) { return handlers_.variant(request); }
  Answer handle(const SelectedReport& report) { return handlers_.selected(report); }
  void opened() { ++in_flight_; }
  void closed() { --in_flight_; }
  void held(void* connection) { held_.push_back(connection); }  // an MHD_Connection, suspended

 private:
  DevelopmentServer() = default;

  void* daemon_ = nullptr;  // MHD_Daemon
  Handlers handlers_;
  LoopbackEndpoint endpoint_;
  size_t in_flight_ = 0;
  std::vector<void*> held_;
};

}  // namespace kiln::development
