// SPDX-License-Identifier: Apache-2.0
#include "frontend/frontend.hpp"

namespace kiln {
namespace {

struct Registered {
  std::string_view name;
  std::unique_ptr<Frontend> (*make)();
};

// Every front end kiln can build with. A new one (DXC, Slang) is a file in frontend/ and a line here.
constexpr Registered kFrontends[] = {
    {"glslang", make_glslang_frontend},
};

}  // namespace

std::vector<std::string> frontend_names() {
  std::vector<std::string> names;
  for (const Registered& f : kFrontends) names.emplace_back(f.name);
  return names;
}

std::unique_ptr<Frontend> make_frontend(std::string_view name) {
  for (const Registered& f : kFrontends)
    if (f.name == name) return f.make();
  return nullptr;
}

}  // namespace kiln
