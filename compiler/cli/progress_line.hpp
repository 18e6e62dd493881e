// SPDX-License-Identifier: Apache-2.0
// The live progress line of `kiln build` on a terminal: one line, redrawn in place, erased before anything
// else is printed to the terminal and when the build ends. Off a terminal (CI logs) there is none: the
// summary printed after the build says it all once.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <mutex>
#include <string>

namespace kiln::cli {

// True when `fd` is a terminal that understands carriage return and "erase line" (not TERM=dumb).
bool is_interactive_terminal(int fd);

// Terminal width of `fd` in columns, or 0 when unknown.
unsigned terminal_columns(int fd);

struct ProgressState {
  size_t done = 0;        // stage sources finished (compiled, failed or served by the cache)
  size_t total = 0;       // distinct stage sources of the build
  size_t cache_hits = 0;  // of `done`, served by the cache
  double seconds = 0;     // since the compile started (the first update)
};

// "kiln: 812/1395 stage sources (58%), 43.1/s, cache hits 12, ~13 s left", cut to `columns` - 1 when
// `columns` is known (a line that wraps cannot be redrawn in place). The rate and the time left count only
// compiled sources: the cache hits are all known when the compile starts.
std::string format_progress(const ProgressState& state, unsigned columns);

class ProgressLine {
 public:
  using Clock = std::chrono::steady_clock;

  ProgressLine(std::FILE* out, unsigned columns, Clock::duration interval = std::chrono::milliseconds(100));

  // Redraws the line, at most once per `interval` (the first and the last state are always drawn).
  void update(size_t done, size_t total, size_t cache_hits, Clock::time_point now = Clock::now());

  // Erases the line (if shown), runs `print`, and leaves the line erased until the next update: a
  // diagnostic printed during the build starts on a clean line, never after a half-drawn progress line.
  template <class Print>
  void print_above(Print&& print) {
    std::lock_guard lock(mutex_);
    erase_locked();
    print();
  }

  // Erases the line for good (the build is over).
  void finish();

 private:
  void erase_locked();

  std::mutex mutex_;
  std::FILE* out_;
  unsigned columns_;
  Clock::duration interval_;
  Clock::time_point start_{};
  Clock::time_point last_draw_{};
  bool shown_ = false;
  bool drawn_once_ = false;
};

}  // namespace kiln::cli
