// SPDX-License-Identifier: Apache-2.0
#include "watch/development_server.hpp"

#include <arpa/inet.h>
#include <microhttpd.h>
#include <netinet/in.h>

#include <algorithm>
#include <cstring>

namespace kiln::development {
namespace {

// A slow or stalled client (one byte a minute) is dropped after this long without progress; the loop never waits on it.
constexpr unsigned kConnectionTimeoutSeconds = 10;
constexpr unsigned kMaxConnections = 32;
constexpr size_t kConnectionMemory = 64 * 1024;  // each connection's headers and buffers: more is 431 or a close

struct Connection {
  std::string body;
  bool report = false;  // POST kSelectedPath, else kVariantPath
  bool too_large = false;
  bool answered = false;
};

MHD_Result send(MHD_Connection* connection, const Answer& answer) {
  MHD_Response* response =
      MHD_create_response_from_buffer(answer.body.size(), const_cast<char*>(answer.body.data()), MHD_RESPMEM_MUST_COPY);
  if (!response) return MHD_NO;
  MHD_add_response_header(response, MHD_HTTP_HEADER_CONTENT_TYPE, "application/json");
  const MHD_Result queued = MHD_queue_response(connection, answer.status, response);
  MHD_destroy_response(response);
  return queued;
}

MHD_Result on_request(void* self, MHD_Connection* connection, const char* url, const char* method, const char*,
                      const char* upload_data, size_t* upload_data_size, void** state) {
  auto& server = *static_cast<DevelopmentServer*>(self);
  auto* request = static_cast<Connection*>(*state);
  if (!request) {  // the headers are in: say no now to what cannot be a request, before any body is read
    request = new Connection;
    *state = request;
    server.opened();
    request->report = std::strcmp(url, kSelectedPath) == 0;
    if (!request->report && std::strcmp(url, kVariantPath) != 0) {
      request->answered = true;
      return send(connection, error_answer(404, std::string("no such path: the endpoint serves POST ") + kVariantPath +
                                                    " and POST " + kSelectedPath));
    }
    if (std::strcmp(method, MHD_HTTP_METHOD_POST) != 0) {
      request->answered = true;
      return send(connection, error_answer(405, "only POST is served"));
    }
    const char* length = MHD_lookup_connection_value(connection, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
    if (length && (std::strlen(length) > 9 || std::strtoull(length, nullptr, 10) > kMaxRequestBytes)) {
      request->answered = true;
      return send(connection, error_answer(413, "a request is at most " + std::to_string(kMaxRequestBytes) + " bytes"));
    }
    return MHD_YES;
  }
  if (request->answered) {  // the body of a request already refused: dropped as it comes
    *upload_data_size = 0;
    return MHD_YES;
  }
  if (*upload_data_size != 0) {  // more of the body (chunked bodies have no length to check first)
    if (request->body.size() + *upload_data_size > kMaxRequestBytes) request->too_large = true;
    else request->body.append(upload_data, *upload_data_size);
    *upload_data_size = 0;
    return MHD_YES;
  }
  request->answered = true;
  if (request->too_large)
    return send(connection, error_answer(413, "a request is at most " + std::to_string(kMaxRequestBytes) + " bytes"));
  Answer answer;
  try {
    if (request->report) {
      Result<SelectedReport, Answer> parsed = parse_selected_report(request->body);
      answer = parsed ? server.handle(*parsed) : parsed.error();
    } else {
      Result<VariantRequest, Answer> parsed = parse_variant_request(request->body);
      std::optional<Answer> handled = parsed ? server.handle(*parsed) : std::optional<Answer>(parsed.error());
      if (!handled) {  // held: libmicrohttpd calls on_request again, with the same state, once it is resumed
        request->answered = false;
        MHD_suspend_connection(connection);
        server.held(connection);
        return MHD_YES;
      }
      answer = std::move(*handled);
    }
  } catch (const std::exception& error) {  // a bug in kiln, said to the client rather than ending watch
    answer = error_answer(500, std::string("kiln watch failed to serve the request: ") + error.what());
  }
  return send(connection, answer);
}

void on_completed(void* self, MHD_Connection*, void** state, MHD_RequestTerminationCode) {
  if (!*state) return;
  delete static_cast<Connection*>(*state);
  *state = nullptr;
  static_cast<DevelopmentServer*>(self)->closed();
}

MHD_Result on_accept(void*, const sockaddr* address, socklen_t) {
  if (address->sa_family != AF_INET) return MHD_NO;
  const auto* in = reinterpret_cast<const sockaddr_in*>(address);
  return (ntohl(in->sin_addr.s_addr) >> 24) == 127 ? MHD_YES : MHD_NO;  // loopback only, whatever the socket says
}

}  // namespace

Result<std::unique_ptr<DevelopmentServer>> DevelopmentServer::start(const LoopbackEndpoint& endpoint, Handlers handlers) {
  std::unique_ptr<DevelopmentServer> server(new DevelopmentServer);
  server->handlers_ = std::move(handlers);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(endpoint.port);
  if (::inet_pton(AF_INET, endpoint.host.c_str(), &address.sin_addr) != 1)
    return failure("cannot listen on " + endpoint.text() + ": not an IPv4 address");
  MHD_Daemon* daemon = MHD_start_daemon(
      MHD_USE_EPOLL | MHD_USE_TURBO | MHD_ALLOW_SUSPEND_RESUME, endpoint.port, &on_accept, nullptr, &on_request, server.get(),
      MHD_OPTION_SOCK_ADDR, reinterpret_cast<sockaddr*>(&address),
      MHD_OPTION_CONNECTION_TIMEOUT, kConnectionTimeoutSeconds,
      MHD_OPTION_CONNECTION_LIMIT, kMaxConnections,
      MHD_OPTION_PER_IP_CONNECTION_LIMIT, kMaxConnections,
      MHD_OPTION_CONNECTION_MEMORY_LIMIT, kConnectionMemory,
      MHD_OPTION_NOTIFY_COMPLETED, &on_completed, server.get(),
      MHD_OPTION_END);
  if (!daemon) return failure("cannot listen on " + endpoint.text() + ": " + std::strerror(errno));
  server->daemon_ = daemon;
  server->endpoint_ = endpoint;
  const MHD_DaemonInfo* port = MHD_get_daemon_info(daemon, MHD_DAEMON_INFO_BIND_PORT);
  if (port) server->endpoint_.port = port->port;
  return server;
}

DevelopmentServer::~DevelopmentServer() {
  release_held();  // a suspended connection must not outlive its daemon
  if (daemon_) MHD_stop_daemon(static_cast<MHD_Daemon*>(daemon_));
}

int DevelopmentServer::fd() const {
  const MHD_DaemonInfo* info = MHD_get_daemon_info(static_cast<MHD_Daemon*>(daemon_), MHD_DAEMON_INFO_EPOLL_FD);
  return info ? info->epoll_fd : -1;
}

int DevelopmentServer::timeout_ms() const {
  MHD_UNSIGNED_LONG_LONG timeout = 0;
  if (MHD_get_timeout(static_cast<MHD_Daemon*>(daemon_), &timeout) != MHD_YES) return -1;
  return static_cast<int>(std::min<MHD_UNSIGNED_LONG_LONG>(timeout, 1000ull * 3600));
}

void DevelopmentServer::run() { MHD_run(static_cast<MHD_Daemon*>(daemon_)); }

void DevelopmentServer::release_held() {
  for (void* connection : held_) MHD_resume_connection(static_cast<MHD_Connection*>(connection));
  held_.clear();
}

}  // namespace kiln::development
