// SPDX-License-Identifier: Apache-2.0
// What the selection benchmarks ask for (bench/pack_open.cpp, bench/usage_recording.cpp), through the C API only so
// that any build of the reader compiles them: the pass with the most variants, and each of its variants' own keywords
// as ids, in a shuffled order (a fixed seed): what a renderer asks for per draw.
#pragma once

#include <algorithm>
#include <random>
#include <vector>

#include "kiln/kiln_reader.h"

inline kiln_pass largest_pass(const kiln_pack* pack) {
  kiln_pass best = 0;
  for (kiln_pass p = 0; p < kiln_pass_count(pack); ++p)
    if (kiln_variant_count(pack, p) > kiln_variant_count(pack, best)) best = p;
  return best;
}

inline std::vector<std::vector<kiln_keyword>> shuffled_requests(const kiln_pack* pack, kiln_pass pass) {
  std::vector<std::vector<kiln_keyword>> requests;
  kiln_error error;
  for (uint32_t v = 0; v < kiln_variant_count(pack, pass); ++v) {
    std::vector<kiln_keyword>& ids = requests.emplace_back();
    for (uint32_t k = 0; k < kiln_variant_keyword_count(pack, pass, v); ++k) {
      kiln_keyword id;
      if (kiln_keyword_find(pack, kiln_variant_keyword(pack, pass, v, k), &id, &error) == KILN_OK) ids.push_back(id);
    }
  }
  std::shuffle(requests.begin(), requests.end(), std::mt19937(2026));
  return requests;
}
