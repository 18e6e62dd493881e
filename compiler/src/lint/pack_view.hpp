// What lint reads of a built pack, typed: the variants of each pass with the binary each stage uses, and the
// stage interfaces of each binary. Read from the manifest in one place (pack_view.cpp), so no rule walks the
// manifest by string keys.
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

// Throws PackError when the manifest lacks what lint reads.
PackView read_pack_view(const PackReader& pack);

}  // namespace kiln
