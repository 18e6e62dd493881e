// SPDX-License-Identifier: Apache-2.0
// Every default kiln states, in one place: the library's option structs, the CLI's --help and the docs take
// them from here (unit.docs.DocsStateTheCodesDefaults checks the docs and --help against `kiln --help`).
#pragma once

#include <chrono>
#include <cstdint>

namespace kiln::defaults {

inline constexpr std::chrono::milliseconds kWorkerTimeout{120'000};        // one compile job (--worker-timeout)
inline constexpr uint64_t kWorkerMemoryLimitMb = 4096;                     // each worker's address space
inline constexpr uint64_t kCacheMaxMb = 1024;                              // the local cache (--cache-max-mb)
inline constexpr uint64_t kMaxFileBytes = uint64_t{4} << 20;              // one input file
inline constexpr std::chrono::milliseconds kRemoteConnectTimeout{1'000};  // --remote-connect-timeout
inline constexpr std::chrono::milliseconds kRemoteTimeout{30'000};        // one remote request (--remote-timeout)
// A transfer that moves fewer bytes than this per second, over this long, is cut off (a drip-feeding or stalled
// server), whatever the request timeout.
inline constexpr long kRemoteLowSpeedBytesPerSecond = 1024;
inline constexpr std::chrono::seconds kRemoteLowSpeedTime{4};
// A request answered with 429 or 5xx (but 507, a full disk) or cut by a reset is tried again, this many times, after
// a pause that doubles from this one.
inline constexpr int kRemoteRetries = 2;
inline constexpr std::chrono::milliseconds kRemoteRetryPause{100};
inline constexpr unsigned kRemoteParallelTransfers = 32;                   // --remote-parallel
// kiln watch: a save is over once no change to an input has come for this long. An editor's save is a sequence
// (write a temporary file, rename it over the old one, set its mode) that takes milliseconds; one round builds it.
inline constexpr std::chrono::milliseconds kWatchQuietPeriod{100};

}  // namespace kiln::defaults
