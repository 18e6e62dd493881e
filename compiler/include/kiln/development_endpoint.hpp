// SPDX-License-Identifier: Apache-2.0
// The development endpoint's protocol, version 1 (docs/development-loop.md, "Protocol, version 1"): its paths and
// bounds, stated once for both ends, kiln watch --serve (kiln/watch.hpp) and the development reader
// (kiln/development_reader.hpp, kiln::reader_dev). Header-only and without dependencies: installed with the
// development reader.
#pragma once

#include <cstddef>

namespace kiln::development {

inline constexpr const char* kVariantPath = "/v1/variant";    // a variant the pack lacks, built and answered
inline constexpr const char* kSelectedPath = "/v1/selected";  // the variants a reader selected: the in-use set
inline constexpr size_t kMaxRequestBytes = 64 * 1024;  // a request's body
inline constexpr size_t kMaxKeywords = 64;             // keywords in one variant
inline constexpr size_t kMaxNameBytes = 256;           // a pass or keyword name
inline constexpr size_t kMaxClientBytes = 64;          // a reader's id in its reports
inline constexpr size_t kMaxReportedVariants = 256;    // variants in one report (a reader sends the rest later)
inline constexpr size_t kMaxAnswerBytes = 64 * 1024;   // an answer's body (diagnostics are cut to fit)
// What watch keeps for the in-use set: what readers asked for (each request), and what they selected (by reader id:
// at most kMaxSelectedReaders readers, the one that reported least recently forgotten for a new one).
inline constexpr size_t kMaxRequestedVariants = 4096;
inline constexpr size_t kMaxSelectedPerReader = 1024;
inline constexpr size_t kMaxSelectedReaders = 16;
inline constexpr size_t kMaxSelectedVariants = 4096;  // over all readers

}  // namespace kiln::development
