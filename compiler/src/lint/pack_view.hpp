// What lint reads of a built pack: the variants of each pass with the binary each stage uses, and the stage
// interfaces of each binary, indexed the way the rules look them up. Made from the typed manifest
// (kiln/manifest.hpp) in one place, pack_view.cpp.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "kiln/pack_reader.hpp"

namespace kiln {

struct PackView {
  struct InterfaceVariable {
    int location = 0;
    std::string name;
    std::string type;  // "vec2", "vec4", ... as reflected
  };
  struct Binary {
    std::string stage;
    std::vector<InterfaceVariable> inputs;
    std::vector<InterfaceVariable> outputs;
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
