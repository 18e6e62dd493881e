// SPDX-License-Identifier: Apache-2.0
// Servers for the remote cache tests, on 127.0.0.1, each stopped by its own PID or thread:
//  - Nginx: Debian's nginx (WebDAV PUT), started from a configuration written into a temporary directory,
//    in the foreground and in one process (`daemon off; master_process off;`), so it runs as the current user
//    and the PID it is started with is the one that is stopped.
//  - FaultServer: a socket thread for the two faults nginx cannot produce on purpose: a body cut short of its
//    Content-Length, and a server that accepts and never answers.
//  - Apache: Debian's apache2 with mod_dav, the same way (-X: one process); WebDav picks nginx or Apache for the
//    tests both servers must pass.
//  - make_test_ca: a CA and a server certificate for 127.0.0.1, made with the openssl CLI at test time.
//  - SlurmCluster: Debian's Slurm as a one-node cluster (munged, slurmctld, slurmd in the foreground, each stopped
//    by its PID) with its own key, configuration, ports, state and logs in a temporary directory.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fcntl.h>
#include <sys/stat.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
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

// A listening socket on a loopback port of the kernel's choice, and that port.
inline int listen_on_loopback(uint16_t& port) {
  int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof address;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), size) != 0 || ::listen(fd, 64) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) != 0)
    throw std::runtime_error("cannot listen on loopback");
  port = ntohs(address.sin_port);
  return fd;
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

// Stops a server the test started: SIGTERM, then SIGKILL if it has not exited within `grace` (a daemon that hangs on
// its way out must not hang the test or outlive it), and reaps it, so its PID is gone when this returns.
inline void stop_process(pid_t pid, std::chrono::milliseconds grace = std::chrono::seconds(10)) {
  if (pid <= 0) return;
  ::kill(pid, SIGTERM);
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + grace;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() >= deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

// In a forked child before exec: the server dies with the test process, also when ctest's timeout kills it.
inline void die_with_parent() { ::prctl(PR_SET_PDEATHSIG, SIGKILL); }

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

// Starts a server in the foreground (it dies with the test) and waits until it accepts connections on `port`. A
// server that exits first (a bad configuration) or never listens fails the test with its log. Returns its PID.
inline pid_t start_server(std::vector<std::string> argv, uint16_t port, const std::filesystem::path& log) {
  std::vector<char*> args;
  for (std::string& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    die_with_parent();
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  const std::string name = std::filesystem::path(argv[0]).filename().string();
  for (int attempt = 0; attempt < 2000; ++attempt) {
    if (accepts_connections(port)) return pid;
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) throw std::runtime_error(name + " exited: " + read_file(log));
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  stop_process(pid);
  throw std::runtime_error(name + " did not start listening: " + read_file(log));
}

// A server process the test started, in a temporary directory of its own (data/ is what it serves; tls/ its test CA)
// on a loopback port; stopped by its PID when it goes (or by stop()).
class ServerProcess {
 public:
  ~ServerProcess() { stop(); }
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  std::string url() const { return std::string(https_ ? "https" : "http") + "://127.0.0.1:" + std::to_string(port_); }
  const std::filesystem::path& directory() const { return dir_.path(); }
  std::filesystem::path data() const { return dir_ / "data"; }
  std::filesystem::path ca_file() const { return dir_ / "tls/ca.pem"; }
  uint16_t port() const { return port_; }
  void stop() {
    stop_process(pid_);
    pid_ = -1;
  }

 protected:
  explicit ServerProcess(bool https) : https_(https) {}
  // The destructor does not run for a constructor that throws: a failed start stops what it started.
  template <class Start>
  void start_or_clean_up(Start start) {
    try {
      start();
    } catch (...) {
      stop();
      throw;
    }
  }

  TempDir dir_;
  uint16_t port_ = 0;
  pid_t pid_ = -1;

 private:
  bool https_;
};

struct NginxConfig {
  std::string location;     // directives inside `location /` besides WebDAV PUT
  bool https = false;       // with a certificate from make_test_ca(<dir>/tls)
};

class Nginx : public ServerProcess {
 public:
  explicit Nginx(NginxConfig config = {}) : ServerProcess(config.https), config_(std::move(config)) {
    start_or_clean_up([this] { start(); });
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
    pid_ = start_server({"/usr/sbin/nginx", "-p", prefix, "-c", conf, "-e", log}, port_, log);
  }

  NginxConfig config_;
};

// Debian's Apache httpd with mod_dav, the second WebDAV server (issue 39): one process (-X) with mpm_event's threads,
// from a configuration written into a temporary directory. It makes no collections for a PUT (409 Conflict; kiln
// answers with MKCOL). Started as root, it serves as www-data: the directory is handed to that user first.
struct DavConfig {
  std::filesystem::path htpasswd;  // if set, writes need a user of this file (basic auth); reads are anonymous
  bool https = false;              // with a certificate from make_test_ca(<dir>/tls)
};

class Apache : public ServerProcess {
 public:
  explicit Apache(DavConfig config = {}) : ServerProcess(config.https), config_(std::move(config)) {
    start_or_clean_up([this] { start(); });
  }
  std::filesystem::path access_log() const { return dir_ / "logs/access.log"; }  // a line per request

 private:
  void start() {
    const std::filesystem::path& d = dir_.path();
    for (const char* sub : {"data", "run", "logs"}) std::filesystem::create_directories(d / sub);
    if (config_.https) make_test_ca(d / "tls");
    port_ = free_port();
    const std::string modules = "/usr/lib/apache2/modules/";
    std::ofstream conf(d / "httpd.conf");
    conf << "ServerRoot " << d.string() << "\nServerName 127.0.0.1\nPidFile " << (d / "run/httpd.pid").string()
         << "\nDefaultRuntimeDir " << (d / "run").string() << "\nListen 127.0.0.1:" << port_
         << "\nErrorLog " << (d / "logs/error.log").string() << "\nLogLevel warn\nCustomLog "
         << (d / "logs/access.log").string() << " \"%h %r %>s\"\n";
    for (const char* module : {"mpm_event", "authz_core", "authn_core", "authn_file", "authz_user", "auth_basic", "dav", "dav_fs"})
      conf << "LoadModule " << module << "_module " << modules << "mod_" << module << ".so\n";
    if (config_.https)
      conf << "LoadModule socache_shmcb_module " << modules << "mod_socache_shmcb.so\nLoadModule ssl_module " << modules
           << "mod_ssl.so\nSSLEngine on\nSSLCertificateFile " << (d / "tls/server.pem").string()
           << "\nSSLCertificateKeyFile " << (d / "tls/server.key").string() << "\n";
    if (::geteuid() == 0) conf << "User www-data\nGroup www-data\n";
    conf << "LimitRequestBody 536870912\nKeepAliveTimeout 30\nMaxKeepAliveRequests 0\n"
         << "DocumentRoot " << (d / "data").string() << "\nDavLockDB " << (d / "run/DavLock").string() << "\n"
         << "<Directory " << (d / "data").string() << ">\n  Dav On\n";
    if (config_.htpasswd.empty()) {
      conf << "  Require all granted\n";
    } else {
      conf << "  AuthType Basic\n  AuthName kiln\n  AuthUserFile " << config_.htpasswd.string()
           << "\n  <RequireAny>\n    Require method GET HEAD OPTIONS\n    Require valid-user\n  </RequireAny>\n";
    }
    conf << "</Directory>\n";
    conf.close();
    if (::geteuid() == 0) {  // the server's user must write data/ and run/ and read its certificate
      const std::vector<std::string> give{"/bin/chown", "-R", "www-data:www-data", d.string()};
      if (run_quietly(give, d) != 0) throw std::runtime_error("chown www-data failed");
      if (!config_.htpasswd.empty()) {  // in the test's own temporary directory: readable, its directory passable
        ::chmod(config_.htpasswd.parent_path().c_str(), 0711);
        ::chmod(config_.htpasswd.c_str(), 0644);
      }
    }
    pid_ = start_server({"/usr/sbin/apache2", "-X", "-d", d.string(), "-f", (d / "httpd.conf").string()}, port_,
                        d / "logs/error.log");
  }

  DavConfig config_;
};

// The WebDAV server of the remote suite: nginx, or Apache when KILN_TEST_DAV_SERVER=apache (the suite's second run,
// remote.apache.*, in tests/CMakeLists.txt). The tests that configure nginx to produce a fault use Nginx itself.
class WebDav {
 public:
  explicit WebDav(DavConfig config = {}) {
    const char* chosen = std::getenv("KILN_TEST_DAV_SERVER");
    if (chosen && std::string(chosen) == "apache") {
      apache_ = std::make_unique<Apache>(config);
      return;
    }
    std::string location;
    if (!config.htpasswd.empty())
      location = "      limit_except GET HEAD { auth_basic \"kiln\"; auth_basic_user_file " + config.htpasswd.string() + "; }";
    nginx_ = std::make_unique<Nginx>(NginxConfig{location, config.https});
  }
  std::string url() const { return nginx_ ? nginx_->url() : apache_->url(); }
  std::filesystem::path data() const { return nginx_ ? nginx_->data() : apache_->data(); }
  std::filesystem::path ca_file() const { return nginx_ ? nginx_->ca_file() : apache_->ca_file(); }
  std::filesystem::path access_log() const { return nginx_ ? nginx_->directory() / "access.log" : apache_->access_log(); }
  void stop() { nginx_ ? nginx_->stop() : apache_->stop(); }

 private:
  std::unique_ptr<Nginx> nginx_;
  std::unique_ptr<Apache> apache_;
};

// Only for what nginx cannot be configured to do: answer with fewer bytes than its Content-Length says
// (Truncated), take connections and never answer (Silent), or never complete a connection (Backlogged: a full
// accept queue, whose connection attempts Linux drops).
class FaultServer {
 public:
  // Truncated: promises 1000 bytes and sends 10. Silent: accepts and never answers. Backlogged: its accept queue is
  // full. Drip: promises 1000 bytes and sends one every 250 ms (under any low-speed limit) until the client goes.
  // Gate: answers 404 to the first `answered_at_once` requests at once; a later one gets the head of a 404 and its
  // body slowly (2,000 bytes a second, over the low-speed limit: nothing times out) until open() is called, or
  // until kGateDeadline passes (then gate_timed_out(), and the gate stays open). Unavailable: answers 503 to the first `count` requests, then
  // 404 to every one. GoesAway: answers 404 to the first `count` requests, then closes its socket (every later
  // connection is refused). Every connection serves one request.
  enum class Mode { Truncated, Silent, Backlogged, Drip, Gate, Unavailable, GoesAway };
  static constexpr std::chrono::seconds kGateDeadline{60};
  explicit FaultServer(Mode mode, int count = 0) : mode_(mode), count_(count) {
    listener_ = listen_on_loopback(port_);
    if (mode_ == Mode::Backlogged) {
      sockaddr_in address{};
      address.sin_family = AF_INET;
      address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      address.sin_port = htons(port_);
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
  int accepted() const { return accepted_; }  // connections accepted so far
  void open() { open_ = true; }
  bool gate_timed_out() const { return timed_out_; }
  bool held_a_request() const { return held_a_request_; }

 private:
  void serve() {
    while (!stopping_) {
      pollfd p{listener_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      int fd = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd < 0) continue;
      ++accepted_;
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
      if (mode_ == Mode::Gate) {
        answer_through_gate(fd);
        continue;
      }
      if (mode_ == Mode::GoesAway) {
        const std::string answer = "HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
        ::send(fd, answer.data(), answer.size(), MSG_NOSIGNAL);
        ::close(fd);
        if (accepted_ >= count_) {
          ::close(listener_);
          listener_ = -1;
          return;
        }
        continue;
      }
      if (mode_ == Mode::Unavailable) {
        const std::string answer = accepted_ <= count_
                                       ? "HTTP/1.1 503 Service Unavailable\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"
                                       : "HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
        ::send(fd, answer.data(), answer.size(), MSG_NOSIGNAL);
        ::close(fd);
        continue;
      }
      const std::string head = "HTTP/1.1 200 OK\r\nContent-Length: 1000\r\nConnection: close\r\n\r\n";
      const std::string answer = mode_ == Mode::Drip ? head : head + "0123456789";
      ssize_t sent = ::send(fd, answer.data(), answer.size(), MSG_NOSIGNAL);
      for (int i = 0; mode_ == Mode::Drip && sent > 0 && i < 1000 && !stopping_; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(250));
        sent = ::send(fd, "k", 1, MSG_NOSIGNAL);
      }
      ::close(fd);
    }
  }

  void answer_through_gate(int fd) {
    constexpr size_t kBody = 400'000, kPerSecond = 2'000;
    const std::string head = "HTTP/1.1 404 Not Found\r\nContent-Length: " + std::to_string(kBody) + "\r\nConnection: close\r\n\r\n";
    bool sending = ::send(fd, head.data(), head.size(), MSG_NOSIGNAL) > 0;
    size_t left = kBody;
    const auto deadline = std::chrono::steady_clock::now() + kGateDeadline;
    if (accepted_ > count_) held_a_request_ = true;
    while (sending && left > 0 && accepted_ > count_ && !open_ && !timed_out_ && !stopping_) {
      if (std::chrono::steady_clock::now() >= deadline) {
        timed_out_ = true;
        break;
      }
      const std::string chunk(std::min(left, kPerSecond / 10), ' ');
      sending = ::send(fd, chunk.data(), chunk.size(), MSG_NOSIGNAL) > 0;
      left -= chunk.size();
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    const std::string rest(left, ' ');
    if (sending) ::send(fd, rest.data(), rest.size(), MSG_NOSIGNAL);
    ::close(fd);
  }

  Mode mode_;
  int count_ = 0;
  std::atomic<bool> open_{false}, timed_out_{false}, held_a_request_{false};
  int listener_ = -1;
  uint16_t port_ = 0;
  std::atomic<bool> stopping_{false};
  std::atomic<int> accepted_{0};
  std::vector<int> held_;
  std::thread thread_;
};

// A one-node Slurm cluster on 127.0.0.1 for the tests of sharded builds: munged with its own key and socket, then
// slurmctld and slurmd, all in the foreground and started by fork/exec, so that the PIDs the destructor stops are
// theirs. Nothing of the machine's own Slurm or MUNGE configuration is read: SLURM_CONF points at this cluster's
// file while it runs (client commands and the jobs it starts read it). slurmd runs jobs as their user only as root.
// Every daemon it started is stopped on every path: by the destructor, and by the constructor itself when one fails
// to start (tested by RemoteSlurm.EveryDaemonIsStoppedWhenOneFailsToStart).
struct SlurmOptions {
  std::string slurmd = "/usr/sbin/slurmd";  // a test names a program that exits at once, to see the clean-up
  std::vector<pid_t>* spawned = nullptr;     // if set, receives the PID of every daemon started
};

class SlurmCluster {
 public:
  explicit SlurmCluster(SlurmOptions options = {}) : options_(std::move(options)) {
    try {
      start();
    } catch (...) {
      stop();  // the destructor does not run for a constructor that throws
      throw;
    }
  }
  ~SlurmCluster() { stop(); }
  SlurmCluster(const SlurmCluster&) = delete;
  SlurmCluster& operator=(const SlurmCluster&) = delete;

  // sbatch, scontrol, ... against this cluster.
  RunResult command(const std::vector<std::string>& argv, const std::filesystem::path& cwd) const { return run(argv, cwd); }
  // A job's state and reason, from `scontrol show job` ("COMPLETED None", "CANCELLED DependencyNeverSatisfied").
  std::string job_state(const std::string& id) const {
    const std::string text = command({"/usr/bin/scontrol", "-o", "show", "job", id}, dir_.path()).out;
    auto field = [&](const std::string& name) {
      size_t at = text.find(" " + name + "=");
      if (at == std::string::npos) return std::string("?");
      at += name.size() + 2;
      return text.substr(at, text.find(' ', at) - at);
    };
    return field("JobState") + " " + field("Reason");
  }
  // The daemons' logs, for a failure message.
  std::string logs() const {
    std::string text;
    for (const char* name : {"munged.log", "slurmctld.log", "slurmd.log"})
      text += std::string("== ") + name + "\n" + read_file(dir_ / name);
    return text;
  }

 private:
  pid_t spawn(std::vector<std::string> argv, const std::string& log) {
    std::vector<char*> args;
    for (std::string& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    const std::string log_path = (dir_ / log).string();
    pid_t pid = ::fork();
    if (pid == 0) {
      die_with_parent();
      int fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::execv(args[0], args.data());
      ::_exit(127);
    }
    pids_.push_back(pid);
    if (options_.spawned) options_.spawned->push_back(pid);
    return pid;
  }
  // Polls `ready` (bounded: a daemon that never gets ready fails the test with the logs, it does not hang it).
  template <typename Ready>
  void wait_until(const std::string& what, Ready ready) {
    for (int attempt = 0; attempt < 3000; ++attempt) {
      if (ready()) return;
      for (auto pid = pids_.begin(); pid != pids_.end(); ++pid) {
        int status = 0;
        if (::waitpid(*pid, &status, WNOHANG) == *pid) {
          pids_.erase(pid);  // reaped: its PID is no longer ours to stop
          throw std::runtime_error("a Slurm daemon exited before " + what + "\n" + logs());
        }
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    throw std::runtime_error("Slurm: no " + what + "\n" + logs());
  }

  void start() {
    const std::filesystem::path& d = dir_.path();
    for (const char* sub : {"state", "spool"}) std::filesystem::create_directories(d / sub);
    if (run_quietly({"/usr/sbin/mungekey", "--create", "--keyfile=" + (d / "munge.key").string()}, d) != 0)
      throw std::runtime_error("mungekey failed");
    std::filesystem::permissions(d / "munge.key", std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
    const std::string socket = (d / "munge.sock").string();
    // --force: munged refuses to run as root, and its directories (here the test's) are not the ones it expects.
    spawn({"/usr/sbin/munged", "--foreground", "--force", "--socket=" + socket, "--key-file=" + (d / "munge.key").string(),
           "--pid-file=" + (d / "munged.pid").string(), "--log-file=" + (d / "munged.log").string(),
           "--seed-file=" + (d / "munge.seed").string()},
          "munged.out");
    wait_until("MUNGE socket", [&] { return std::filesystem::exists(socket); });

    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    std::string controller(host);
    controller = controller.substr(0, controller.find('.'));  // slurmctld compares the short name with its own
    const uint16_t controller_port = free_port(), node_port = free_port();
    // linuxproc/none plugins: no cgroups and no accounting, so the cluster runs in a container too.
    std::ofstream(d / "slurm.conf")
        << "ClusterName=kilntest\nSlurmctldHost=" << controller << "(127.0.0.1)\n"
        << "SlurmctldPort=" << controller_port << "\nSlurmdPort=" << node_port << "\n"
        << "AuthType=auth/munge\nCredType=cred/munge\nAuthInfo=socket=" << socket << "\n"
        << "SlurmUser=root\nSlurmdUser=root\n"
        << "StateSaveLocation=" << (d / "state").string() << "\nSlurmdSpoolDir=" << (d / "spool").string() << "\n"
        << "SlurmctldPidFile=" << (d / "slurmctld.pid").string() << "\nSlurmdPidFile=" << (d / "slurmd.pid").string() << "\n"
        << "SlurmctldLogFile=" << (d / "slurmctld.log").string() << "\nSlurmdLogFile=" << (d / "slurmd.log").string() << "\n"
        << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nJobAcctGatherType=jobacct_gather/none\n"
        << "AccountingStorageType=accounting_storage/none\nSwitchType=switch/none\nMpiDefault=none\n"
        << "SelectType=select/cons_tres\nSelectTypeParameters=CR_CPU\nSchedulerType=sched/backfill\nReturnToService=2\n"
        << "NodeName=kilnnode NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN\n"
        << "PartitionName=kiln Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n";
    const std::string conf = (d / "slurm.conf").string();
    ::setenv("SLURM_CONF", conf.c_str(), 1);
    spawn({"/usr/sbin/slurmctld", "-D", "-i", "-f", conf}, "slurmctld.out");
    spawn({options_.slurmd, "-D", "-N", "kilnnode", "-f", conf}, "slurmd.out");
    wait_until("idle node", [&] {
      RunResult r = command({"/usr/bin/sinfo", "-h", "-N", "-o", "%t"}, d);
      return r.exit_code == 0 && r.out == "idle\n";
    });
  }

  void stop() {
    // The node first, then the controller, then MUNGE, which both authenticate with.
    for (auto pid = pids_.rbegin(); pid != pids_.rend(); ++pid) stop_process(*pid);
    pids_.clear();
    ::unsetenv("SLURM_CONF");
  }

  SlurmOptions options_;
  TempDir dir_;
  std::vector<pid_t> pids_;
};

}  // namespace kiln::testing
