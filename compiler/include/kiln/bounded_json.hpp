// SPDX-License-Identifier: Apache-2.0
// The one decoder of JSON and CBOR bytes from outside (pack definitions, scene profiles, manifests, cache and
// remote records, worker pipes): sizes and nesting depth are checked before nlohmann recurses or allocates, a
// number outside the double range or a repeated object key is an error, and every failure is one exception type
// with the byte offset where it was found. Not installed: only kiln's own code and the reader's sources include it.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace kiln {

struct JsonLimits {
  size_t max_bytes;  // the input as a whole
  size_t max_depth;  // arrays and objects nested in each other (the top-level value is depth 1)
};

// Deeper than anything kiln writes (a manifest nests 6 levels, a compile record 7) and far below what overflows a
// thread's stack: nlohmann's CBOR reader recurses once per level, and 200,000 levels crashed a transfer thread.
inline constexpr size_t kMaxJsonDepth = 64;

class JsonDecodeError : public std::runtime_error {
 public:
  JsonDecodeError(const std::string& message, size_t offset) : std::runtime_error(message), offset_(offset) {}
  // The byte the problem was found at (0-based; for a repeated key or a nesting too deep, just past its token).
  size_t offset() const { return offset_; }

 private:
  size_t offset_;
};

// JSON text. Throws JsonDecodeError: a syntax error (nlohmann's reason), a number outside the double range, a key
// repeated in one object, nesting deeper than the limit, or input over the size limit.
nlohmann::json parse_json_bounded(std::string_view text, JsonLimits limits);
// CBOR, as nlohmann writes it. Throws JsonDecodeError as parse_json_bounded does.
nlohmann::json decode_cbor_bounded(std::string_view bytes, JsonLimits limits);

}  // namespace kiln
