// SPDX-License-Identifier: Apache-2.0
// Content hashing (xxHash XXH3): 128-bit keys for caches and dedupe, 64-bit checksums for files.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace kiln {

struct Hash128 {
  uint64_t low = 0;
  uint64_t high = 0;
  friend bool operator==(const Hash128&, const Hash128&) = default;
  friend auto operator<=>(const Hash128&, const Hash128&) = default;
  std::string hex() const;  // 32 lowercase hex digits
};

Hash128 hash128(std::string_view bytes);
uint64_t hash64(std::string_view bytes);
uint64_t hash64(const std::vector<std::string_view>& parts);  // the same as hash64 of the parts joined
std::string hex64(uint64_t value);

// Streams many fields into one 128-bit hash; each field is length-prefixed so ("ab","c") != ("a","bc").
class Hasher {
 public:
  Hasher();
  ~Hasher();
  Hasher(const Hasher&) = delete;
  Hasher& operator=(const Hasher&) = delete;
  Hasher& add(std::string_view field);
  Hasher& add(uint64_t value);
  Hash128 finish() const;

 private:
  void* state_;
};

}  // namespace kiln
