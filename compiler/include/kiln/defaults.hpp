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
inline constexpr unsigned kRemoteParallelTransfers = 32;                   // --remote-parallel

}  // namespace kiln::defaults
