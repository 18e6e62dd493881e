// SPDX-License-Identifier: Apache-2.0
// The progress line of `kiln build` on a terminal: what it says, how often it is redrawn, and that it
// is erased before anything else is printed (the terminal itself is exercised in diag.Cli tests).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "progress_line.hpp"

namespace kiln::cli {
namespace {

using namespace std::chrono_literals;

// A FILE* whose bytes the test can read.
class MemoryStream {
 public:
  MemoryStream() : file_(::open_memstream(&data_, &size_)) {}
  ~MemoryStream() {
    std::fclose(file_);
    std::free(data_);
  }
  std::FILE* file() { return file_; }
  std::string text() {
    std::fflush(file_);
    return std::string(data_, size_);
  }

 private:
  char* data_ = nullptr;
  size_t size_ = 0;
  std::FILE* file_;
};

TEST(ProgressLine, SaysHowManyStageSourcesAreDoneTheRateTheTimeLeftAndTheCacheHits) {
  EXPECT_EQ(format_progress({0, 1395, 0, 0.0}, 0), "kiln: 0/1395 stage sources (0%)");
  // The rate counts compiled sources only: 400 cache hits were known when the compile started.
  EXPECT_EQ(format_progress({800, 1395, 400, 10.0}, 0),
            "kiln: 800/1395 stage sources (57%), 40.0/s, ~15 s left, cache hits 400");
  // No estimate in the first second, none when done.
  EXPECT_EQ(format_progress({10, 1395, 0, 0.5}, 0), "kiln: 10/1395 stage sources (0%), 20.0/s");
  EXPECT_EQ(format_progress({1395, 1395, 0, 20.0}, 0), "kiln: 1395/1395 stage sources (100%), 69.8/s");
  // A warm build: everything from the cache, nothing compiled, no rate.
  EXPECT_EQ(format_progress({1395, 1395, 1395, 0.2}, 0), "kiln: 1395/1395 stage sources (100%), cache hits 1395");
}

TEST(ProgressLine, IsCutToTheTerminalWidthSoThatItNeverWraps) {
  const std::string line = format_progress({800, 1395, 400, 10.0}, 40);
  EXPECT_EQ(line, "kiln: 800/1395 stage sources (57%), 40.");
  EXPECT_EQ(line.size(), 39u);
}

TEST(ProgressLine, IsRedrawnInPlaceAtMostOncePerIntervalButAlwaysAtTheEnd) {
  MemoryStream out;
  ProgressLine progress(out.file(), 0, 100ms);
  const auto t0 = ProgressLine::Clock::time_point{} + 1h;
  progress.update(0, 4, 0, t0);
  progress.update(1, 4, 0, t0 + 50ms);   // too soon: not drawn
  progress.update(2, 4, 0, t0 + 150ms);  // drawn
  progress.update(3, 4, 0, t0 + 160ms);  // too soon
  progress.update(4, 4, 0, t0 + 170ms);  // the last: always drawn
  EXPECT_EQ(out.text(),
            "\rkiln: 0/4 stage sources (0%)\033[K"
            "\rkiln: 2/4 stage sources (50%), 13.3/s\033[K"
            "\rkiln: 4/4 stage sources (100%), 23.5/s\033[K");
  const std::string drawn = out.text();
  progress.finish();
  progress.finish();  // erased once
  EXPECT_EQ(out.text(), drawn + "\r\033[K");
}

TEST(ProgressLine, WhatIsPrintedDuringTheBuildStartsOnAClearedLine) {
  MemoryStream out;
  ProgressLine progress(out.file(), 0, 100ms);
  // Before any progress there is nothing to erase.
  progress.print_above([&] { std::fputs("early\n", out.file()); });
  const auto t0 = ProgressLine::Clock::time_point{} + 1h;
  progress.update(0, 2, 0, t0);
  progress.print_above([&] { std::fputs("S.hlsl:1:1: error[K1401]: oops\n", out.file()); });
  progress.update(1, 2, 0, t0 + 10ms);  // the line is gone: redrawn at once, whatever the interval
  progress.finish();
  EXPECT_EQ(out.text(),
            "early\n"
            "\rkiln: 0/2 stage sources (0%)\033[K"
            "\r\033[KS.hlsl:1:1: error[K1401]: oops\n"
            "\rkiln: 1/2 stage sources (50%), 100.0/s\033[K"
            "\r\033[K");
}

}  // namespace
}  // namespace kiln::cli
