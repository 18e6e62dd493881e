// SPDX-License-Identifier: Apache-2.0
// Development mode for a PackReader (docs/reader.md, "On-demand variants"): a variant the pack lacks is asked of
// `kiln watch --serve` (docs/development-loop.md), which builds it into the pack it publishes. A library of its own,
// kiln::reader_dev (libcurl): a release build does not link it, so a release reader never opens a connection.
//
// Opt-in only, twice over: the game links kiln::reader_dev and makes a DevelopmentReader, explicitly (open) or when
// the development-only variable KILN_DEVELOPMENT_ENDPOINT is set (from_environment). The endpoint is 127.0.0.1 only.
// Every answer is untrusted: its size, its JSON (depth, fields, names) and the archive it names are checked.
//
// It also tells watch what the game selects (poll_update(): the variants the reader served since it was opened, as
// the reader's usage recording counts them), so that each round of kiln watch builds those first.
#pragma once

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kiln/pack_reader.hpp"

namespace kiln {

class DevelopmentReader {
 public:
  struct Options {
    // "127.0.0.1:PORT". Empty: KILN_DEVELOPMENT_ENDPOINT when it names one, else the endpoint file kiln watch
    // writes beside the manifest (<pack>.endpoint), read when a request is made.
    std::string endpoint;
    std::chrono::milliseconds answer_timeout{60000};  // the longest a background request waits for watch's answer
    // The usage log (docs/usage.md) that poll_update() reads back to report what the game selected. Empty: open()
    // starts the reader's usage recording (PackReader::record_usage) into a file of its own, in $XDG_RUNTIME_DIR
    // (else the temporary directory), removed when this goes. A game that records usage itself gives its log here,
    // having called record_usage first: open() then leaves recording as it is.
    std::filesystem::path selected_log;
    std::chrono::milliseconds report_interval{500};  // poll_update() reads the log and reports at most this often
  };

  // `reader` (opened from `manifest`) stays the caller's and must outlive this. Connects to nothing yet.
  static PackResult<DevelopmentReader> open(PackReader& reader, const std::filesystem::path& manifest, Options options);
  static PackResult<DevelopmentReader> open(PackReader& reader, const std::filesystem::path& manifest);
  // open() when KILN_DEVELOPMENT_ENDPOINT is set ("127.0.0.1:PORT", or "auto" for the endpoint file), else nothing:
  // a game may call it in every build and stay offline unless a developer sets the variable.
  static std::optional<PackResult<DevelopmentReader>> from_environment(PackReader& reader, const std::filesystem::path& manifest);

  DevelopmentReader(DevelopmentReader&&) noexcept;
  DevelopmentReader& operator=(DevelopmentReader&&) noexcept;
  ~DevelopmentReader();  // waits for a background request under way (bounded by answer_timeout)

  // (a) The variant. When the pack lacks it (Stripped), asks watch for it and waits up to `timeout` for the answer,
  // then switches the reader to the pack that has it (poll_update(), whose changes are lost to the caller: select
  // again what it cares about) and selects it. Other errors (an unknown keyword...) are returned as select gives them.
  PackResult<SelectedVariant> select_or_wait(std::string_view pass, const std::vector<std::string>& keywords,
                                             std::chrono::milliseconds timeout);

  // (b) The variant, or when the pack lacks it the nearest variant of the pass now (fewest keywords differing,
  // `nearest` set) while the request goes to watch in the background: a later poll_update() lists the real one as
  // Added. A keyword set already asked for is not asked again.
  struct Selection {
    SelectedVariant variant;
    bool nearest = false;
  };
  PackResult<Selection> select_or_nearest(std::string_view pass, const std::vector<std::string>& keywords);

  // One request, waited for up to `timeout`: the archive ("<pack>.<xxh3>.kpack") watch published with the variant.
  PackResult<std::string> request(std::string_view pass, const std::vector<std::string>& keywords,
                                  std::chrono::milliseconds timeout);
  // The reader's poll_update(), then report_selected(): the call a game makes once a frame in any case.
  PackResult<PackUpdate> poll_update() noexcept;
  // What the game selected since the last report, sent to watch (POST /v1/selected) in the background: at most once
  // per Options::report_interval, and only when the reader's log holds keyword sets not reported yet (a flush of the
  // usage log and a read of it; nothing on the network otherwise). Never blocks on watch; select() pays nothing
  // more than usage recording's one relaxed atomic increment. A failed report is sent again later.
  void report_selected() noexcept;
  // Variants watch has taken from this reader's reports.
  size_t reported() const;

  // Background requests sent and not yet answered (or failed).
  size_t pending() const;
  // The last background request's error, if it failed ("" if none).
  std::string last_error() const;

 private:
  struct Impl;
  explicit DevelopmentReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace kiln
