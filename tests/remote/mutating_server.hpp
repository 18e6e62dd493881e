// SPDX-License-Identifier: Apache-2.0
// The remote-response fuzzer's server: a loopback HTTP server that answers each GET with the bytes a real nginx
// stored for that path, mutated by a seeded generator: as an attacker on an `http://` path would. Records (under
// /ac/) are mostly resealed after their payload is changed (size and SHA-256 made right, so that the damage
// reaches the decoder behind the checksum, as the forged record of 200,000 nested CBOR arrays did); blobs (under
// /cas/) and some records are damaged as they are (bits, truncation, extension). Serves reads only.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "remote/remote_cache.hpp"
#include "servers.hpp"
#include "test_support.hpp"

namespace kiln::testing {

class MutatingServer {
 public:
  // `data`: the directory nginx stored the entries in (Nginx::data()); `seed`: the generator's, so a run repeats.
  MutatingServer(std::filesystem::path data, uint32_t seed) : data_(std::move(data)), random_(seed) {
    listener_ = listen_on_loopback(port_);
    thread_ = std::thread([this] { serve(); });
  }
  ~MutatingServer() {
    stopping_ = true;
    thread_.join();
    ::close(listener_);
  }
  MutatingServer(const MutatingServer&) = delete;
  MutatingServer& operator=(const MutatingServer&) = delete;

  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }
  size_t answered() const { return answered_; }
  size_t resealed() const { return resealed_; }

 private:
  static constexpr size_t kRecordHeader = 88;  // magic, format, kind, key, payload size, payload SHA-256

  void serve() {
    while (!stopping_) {
      pollfd p{listener_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      int fd = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd < 0) continue;
      std::string request;
      char buffer[4096];
      while (request.find("\r\n\r\n") == std::string::npos && request.size() < 65536) {
        pollfd r{fd, POLLIN, 0};
        if (::poll(&r, 1, 2000) <= 0) break;
        const ssize_t n = ::read(fd, buffer, sizeof buffer);
        if (n <= 0) break;
        request.append(buffer, static_cast<size_t>(n));
      }
      std::string answer = "HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
      const size_t space = request.find(' '), end = request.find(' ', space + 1);
      const std::string method = request.substr(0, space);
      const std::string path = space == std::string::npos || end == std::string::npos ? "" : request.substr(space + 1, end - space - 1);
      if ((method == "GET" || method == "HEAD") && path.find("..") == std::string::npos &&
          std::filesystem::is_regular_file(data_ / path.substr(1))) {
        const std::string body = mutate(read_file(data_ / path.substr(1)), path.find("/ac/") != std::string::npos);
        answer = "HTTP/1.1 200 OK\r\nContent-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" +
                 (method == "GET" ? body : std::string());
        ++answered_;
      }
      for (size_t sent = 0; sent < answer.size();) {
        const ssize_t n = ::send(fd, answer.data() + sent, answer.size() - sent, MSG_NOSIGNAL);
        if (n <= 0) break;
        sent += static_cast<size_t>(n);
      }
      ::close(fd);
    }
  }

  size_t below(size_t n) { return n == 0 ? 0 : std::uniform_int_distribution<size_t>(0, n - 1)(random_); }

  // Bit flips, truncation, extension, a stretch of random bytes, or a CBOR nesting bomb in place of the rest.
  std::string damage(std::string bytes) {
    switch (below(5)) {
      case 0:
        for (size_t flips = 1 + below(8); flips > 0 && !bytes.empty(); --flips)
          bytes[below(bytes.size())] ^= static_cast<char>(1 << below(8));
        break;
      case 1: bytes.resize(below(bytes.size() + 1)); break;
      case 2:
        for (size_t extra = 1 + below(64); extra > 0; --extra) bytes += static_cast<char>(below(256));
        break;
      case 3:
        if (!bytes.empty()) {
          const size_t at = below(bytes.size());
          for (size_t i = at; i < std::min(bytes.size(), at + 1 + below(32)); ++i) bytes[i] = static_cast<char>(below(256));
        }
        break;
      default:
        bytes.resize(below(bytes.size() + 1));
        bytes += std::string(200000, '\x81') + '\xf6';  // arrays nested 200,000 deep, then null
    }
    return bytes;
  }

  std::string mutate(std::string bytes, bool record) {
    const size_t choice = below(10);
    if (choice == 0) return bytes;  // some answers are whole, so the builds also take good entries
    if (record && choice >= 3 && bytes.size() >= kRecordHeader) {
      // Reseal: the payload damaged, its size and SHA-256 in the header made right.
      std::string payload = damage(bytes.substr(kRecordHeader));
      std::string resealed = bytes.substr(0, kRecordHeader);
      const uint64_t size = payload.size();
      std::memcpy(resealed.data() + 48, &size, 8);  // little-endian, as kiln writes it
      const RemoteKey digest = sha256(payload);
      std::memcpy(resealed.data() + 56, digest.bytes.data(), 32);
      ++resealed_;
      return resealed + payload;
    }
    return damage(std::move(bytes));
  }

  std::filesystem::path data_;
  std::mt19937 random_;
  int listener_ = -1;
  uint16_t port_ = 0;
  std::atomic<bool> stopping_{false};
  std::atomic<size_t> answered_{0}, resealed_{0};
  std::thread thread_;
};

}  // namespace kiln::testing
