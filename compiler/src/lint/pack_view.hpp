// SPDX-License-Identifier: Apache-2.0
// What lint reads of a built pack: the variants of each pass with the binary each stage uses, indexed the way
// the rules look them up. Made from the typed manifest
// (kiln/manifest.hpp) in one place, pack_view.cpp.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "kiln/pack_reader.hpp"

namespace kiln {

struct PackView {
  struct Binary {
    std::string stage;
  };
  struct Variant {
    std::vector<std::string> keywords;      // sorted, as stored
    std::map<std::string, size_t> binaries;  // stage -> index into `binaries`
  };
  struct Pass {
    std::string name;
    std::vector<Variant> variants;
  };
  std::vector<Pass> passes;
  std::vector<Binary> binaries;
};

PackView read_pack_view(const PackReader& pack);

}  // namespace kiln
