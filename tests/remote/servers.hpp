// Servers for the remote cache tests, on 127.0.0.1, each stopped by its own PID or thread:
//  - Nginx: Debian's nginx (WebDAV PUT), started from a configuration written into a temporary directory,
//    in the foreground and in one process (`daemon off; master_process off;`), so it runs as the current user
//    and the PID it is started with is the one that is stopped.
//  - FaultServer: a socket thread for the two faults nginx cannot produce on purpose: a body cut short of its
//    Content-Length, and a server that accepts and never answers.
//  - make_test_ca: a CA and a server certificate for 127.0.0.1, made with the openssl CLI at test time.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "test_support.hpp"

namespace kiln::testing {

// A port nothing listens on right now (the kernel's choice, released at once).
inline uint16_t free_port() {
  int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof address;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), size) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) != 0)
    throw std::runtime_error("cannot bind a loopback port");
  ::close(fd);
  return ntohs(address.sin_port);
}

inline bool accepts_connections(uint16_t port) {
  int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(port);
  const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  ::close(fd);
  return ok;
}

inline int run_quietly(const std::vector<std::string>& argv, const std::filesystem::path& cwd) {
  return run(argv, cwd).exit_code;
}

// The CA certificate (ca.pem) and a certificate for 127.0.0.1 it signed (server.pem, server.key) in `dir`.
inline void make_test_ca(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "server.ext") << "subjectAltName=IP:127.0.0.1\n";
  const std::string openssl = "/usr/bin/openssl";
  const std::vector<std::vector<std::string>> steps{
      {openssl, "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes", "-keyout", "ca.key",
       "-out", "ca.pem", "-days", "2", "-subj", "/CN=kiln test CA"},
      {openssl, "req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:P-256", "-nodes", "-keyout", "server.key", "-out",
       "server.csr", "-subj", "/CN=127.0.0.1"},
      {openssl, "x509", "-req", "-in", "server.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial", "-out",
       "server.pem", "-days", "2", "-extfile", "server.ext"}};
  for (const auto& step : steps)
    if (run_quietly(step, dir) != 0) throw std::runtime_error("openssl failed: " + step[1]);
}

struct NginxConfig {
  std::string location;     // directives inside `location /` besides WebDAV PUT
  bool https = false;       // with a certificate from make_test_ca(<dir>/tls)
};

class Nginx {
 public:
  explicit Nginx(NginxConfig config = {}) : config_(std::move(config)) { start(); }
  ~Nginx() { stop(); }
  Nginx(const Nginx&) = delete;
  Nginx& operator=(const Nginx&) = delete;

  std::string url() const { return std::string(config_.https ? "https" : "http") + "://127.0.0.1:" + std::to_string(port_); }
  const std::filesystem::path& directory() const { return dir_.path(); }
  std::filesystem::path data() const { return dir_ / "data"; }
  std::filesystem::path ca_file() const { return dir_ / "tls/ca.pem"; }
  uint16_t port() const { return port_; }

  void stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }

 private:
  void start() {
    const std::filesystem::path& d = dir_.path();
    std::filesystem::create_directories(d / "data");
    std::filesystem::create_directories(d / "tmp");
    if (config_.https) make_test_ca(d / "tls");
    port_ = free_port();
    std::string tls;
    if (config_.https)
      tls = "    ssl_certificate " + (d / "tls/server.pem").string() + ";\n    ssl_certificate_key " +
            (d / "tls/server.key").string() + ";\n";
    std::ofstream(d / "nginx.conf")
        << "daemon off;\nmaster_process off;\nworker_processes 1;\n"
        << "pid " << (d / "nginx.pid").string() << ";\nerror_log " << (d / "error.log").string() << ";\n"
        << "events { worker_connections 128; }\n"
        << "http {\n  access_log " << (d / "access.log").string() << ";\n"
        << "  client_body_temp_path " << (d / "tmp/body").string() << ";\n  proxy_temp_path " << (d / "tmp/proxy").string()
        << ";\n  fastcgi_temp_path " << (d / "tmp/fastcgi").string() << ";\n  uwsgi_temp_path " << (d / "tmp/uwsgi").string()
        << ";\n  scgi_temp_path " << (d / "tmp/scgi").string() << ";\n"
        << "  client_max_body_size 512m;\n"
        << "  server {\n    listen 127.0.0.1:" << port_ << (config_.https ? " ssl" : "") << ";\n" << tls
        << "    root " << (d / "data").string() << ";\n"
        << "    location / {\n      dav_methods PUT;\n      create_full_put_path on;\n      dav_access user:rw;\n"
        << config_.location << "\n    }\n  }\n}\n";
    const std::string conf = (d / "nginx.conf").string(), prefix = d.string() + "/", log = (d / "error.log").string();
    std::vector<std::string> argv{"/usr/sbin/nginx", "-p", prefix, "-c", conf, "-e", log};
    std::vector<char*> args;
    for (std::string& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::execv(args[0], args.data());
      ::_exit(127);
    }
    // Ready when it accepts connections; an nginx that exited (a bad configuration) fails the test with its log.
    for (int attempt = 0; attempt < 2000; ++attempt) {
      if (accepts_connections(port_)) return;
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("nginx exited: " + read_file(d / "error.log"));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    throw std::runtime_error("nginx did not start listening: " + read_file(d / "error.log"));
  }

  NginxConfig config_;
  TempDir dir_;
  uint16_t port_ = 0;
  pid_t pid_ = -1;
};

// Only for what nginx cannot be configured to do: answer with fewer bytes than its Content-Length says
// (Truncated), take connections and never answer (Silent), or never complete a connection (Backlogged: a full
// accept queue, whose connection attempts Linux drops).
class FaultServer {
 public:
  enum class Mode { Truncated, Silent, Backlogged };
  explicit FaultServer(Mode mode) : mode_(mode) {
    listener_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof address;
    if (::bind(listener_, reinterpret_cast<sockaddr*>(&address), size) != 0 || ::listen(listener_, 64) != 0 ||
        ::getsockname(listener_, reinterpret_cast<sockaddr*>(&address), &size) != 0)
      throw std::runtime_error("cannot listen on loopback");
    port_ = ntohs(address.sin_port);
    if (mode_ == Mode::Backlogged) {
      // Connections are made until one does not complete: the queue is full from then on (how many it holds
      // differs between kernels). The 200 ms wait decides nothing but how soon the probing stops.
      ::listen(listener_, 0);
      for (int i = 0; i < 16; ++i) {
        int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
        ::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
        pollfd p{fd, POLLOUT, 0};
        int error = 0;
        socklen_t length = sizeof error;
        if (::poll(&p, 1, 200) == 1 && ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &length) == 0 && error == 0) {
          held_.push_back(fd);
          continue;
        }
        ::close(fd);
        return;
      }
      throw std::runtime_error("the accept queue never filled up");
    }
    thread_ = std::thread([this] { serve(); });
  }
  ~FaultServer() {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
    for (int fd : held_) ::close(fd);
    ::close(listener_);
  }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }

 private:
  void serve() {
    while (!stopping_) {
      pollfd p{listener_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      int fd = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd < 0) continue;
      if (mode_ == Mode::Silent) {
        held_.push_back(fd);  // open, unanswered, until the server stops
        continue;
      }
      // Read the request head, then promise 1000 bytes and send 10.
      std::string request;
      char buffer[4096];
      while (request.find("\r\n\r\n") == std::string::npos) {
        pollfd r{fd, POLLIN, 0};
        if (::poll(&r, 1, 2000) <= 0) break;
        ssize_t n = ::read(fd, buffer, sizeof buffer);
        if (n <= 0) break;
        request.append(buffer, static_cast<size_t>(n));
      }
      const std::string answer = "HTTP/1.1 200 OK\r\nContent-Length: 1000\r\nConnection: close\r\n\r\n0123456789";
      [[maybe_unused]] ssize_t sent = ::send(fd, answer.data(), answer.size(), MSG_NOSIGNAL);
      ::close(fd);
    }
  }

  Mode mode_;
  int listener_ = -1;
  uint16_t port_ = 0;
  std::atomic<bool> stopping_{false};
  std::vector<int> held_;
  std::thread thread_;
};

}  // namespace kiln::testing
