// SPDX-License-Identifier: Apache-2.0
// kiln watch as a library (docs/development-loop.md): builds a pack, then builds it again whenever an input it read
// changes, the variants in use first; with a development endpoint (serve), readers in development mode ask it for
// the variants the pack lacks. The CLI (cli/watch_verb.cpp) parses the arguments and prints what this reports.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "kiln/build.hpp"
#include "kiln/development_endpoint.hpp"
#include "kiln/diagnostics.hpp"
#include "kiln/result.hpp"

namespace kiln {

// An address the development endpoint may listen on: IPv4 loopback only (127.0.0.0/8), any port (0: the kernel's
// choice). Nothing but a local process can reach it; see docs/threat-model.md.
struct LoopbackEndpoint {
  std::string host = "127.0.0.1";
  uint16_t port = 0;
  std::string text() const { return host + ":" + std::to_string(port); }
};

// "127.0.0.1:PORT" (or "localhost:PORT"); the error says what is wrong, for `kiln: error: --serve ...: <error>`.
Result<LoopbackEndpoint> parse_loopback_endpoint(const std::string& text);

struct WatchOptions {
  BuildOptions build;                             // the full pack's options (usage_logs empty)
  std::vector<std::filesystem::path> usage_logs;  // --usage: the in-use variants, read again each round
  std::optional<LoopbackEndpoint> serve;          // --serve: the development endpoint
  bool in_use_only = false;                       // --in-use-only: no full pack; the in-use set and requests only
};

// What watch tells its caller; every member may be empty.
struct WatchListener {
  // A build's diagnostics, each once per round; and watch's own: K1801 (it cannot watch) and K1802 (it cannot
  // listen), errors that end it, and K1803 (the in-use set is full), a warning once per watch.
  std::function<void(const Diagnostic&)> diagnostic;
  std::function<void(const std::string&)> status;  // one line per round, per request and report served, and the endpoint
};

// Runs until `signal_fd` (a signalfd for SIGINT and SIGTERM, which the caller has blocked) is readable. Returns the
// exit status: 0 when a signal ended it, 3 (environment) when it could not watch or listen (K1801, K1802).
int watch(const WatchOptions& options, int signal_fd, const WatchListener& listener);

// The development endpoint (docs/development-loop.md, "On-demand variants"); its protocol's paths and bounds are
// kiln/development_endpoint.hpp's.
namespace development {
// The file beside the manifest that names the endpoint: "<pack>.endpoint", one line "127.0.0.1:PORT".
std::filesystem::path endpoint_file(const std::filesystem::path& output_dir, const std::string& pack_name);
}  // namespace development

}  // namespace kiln
