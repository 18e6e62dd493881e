// SPDX-License-Identifier: Apache-2.0
#include "progress_line.hpp"

#include <sys/ioctl.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>

namespace kiln::cli {

bool is_interactive_terminal(int fd) {
  if (!::isatty(fd)) return false;
  const char* term = std::getenv("TERM");
  return term && *term && std::strcmp(term, "dumb") != 0;
}

unsigned terminal_columns(int fd) {
  winsize size{};
  if (::ioctl(fd, TIOCGWINSZ, &size) != 0) return 0;
  return size.ws_col;
}

std::string format_progress(const ProgressState& s, unsigned columns) {
  char text[160];
  const unsigned percent = s.total ? static_cast<unsigned>(s.done * 100 / s.total) : 100;
  int n = std::snprintf(text, sizeof text, "kiln: %zu/%zu stage sources (%u%%)", s.done, s.total, percent);
  const size_t compiled = s.done - s.cache_hits;
  if (s.seconds > 0 && compiled > 0) {
    const double rate = compiled / s.seconds;
    n += std::snprintf(text + n, sizeof text - n, ", %.1f/s", rate);
    if (s.done < s.total && s.seconds >= 1) {
      const double left = (s.total - s.done) / rate;
      n += std::snprintf(text + n, sizeof text - n, ", ~%.0f s left", std::ceil(left));
    }
  }
  if (s.cache_hits) std::snprintf(text + n, sizeof text - n, ", cache hits %zu", s.cache_hits);
  std::string line = text;
  if (columns > 1 && line.size() > columns - 1) line.resize(columns - 1);
  return line;
}

ProgressLine::ProgressLine(std::FILE* out, unsigned columns, Clock::duration interval)
    : out_(out), columns_(columns), interval_(interval) {}

void ProgressLine::update(size_t done, size_t total, size_t cache_hits, Clock::time_point now) {
  std::lock_guard lock(mutex_);
  // The rate counts from the first update: the compile starts then, after loading (preprocessing streams into it).
  if (!drawn_once_) start_ = now;
  const bool last = done >= total;
  // Throttled only while shown: a line erased for a diagnostic comes back at once.
  if (shown_ && !last && now - last_draw_ < interval_) return;
  const ProgressState state{done, total, cache_hits, std::chrono::duration<double>(now - start_).count()};
  std::fprintf(out_, "\r%s\033[K", format_progress(state, columns_).c_str());
  std::fflush(out_);
  last_draw_ = now;
  shown_ = drawn_once_ = true;
}

void ProgressLine::erase_locked() {
  if (!shown_) return;
  std::fputs("\r\033[K", out_);
  std::fflush(out_);
  shown_ = false;
}

void ProgressLine::finish() {
  std::lock_guard lock(mutex_);
  erase_locked();
}

}  // namespace kiln::cli
