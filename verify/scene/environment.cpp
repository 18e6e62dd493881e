// SPDX-License-Identifier: Apache-2.0
#include "scene/environment.hpp"
#include "scene/verify_error.hpp"

#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace kiln::render {

std::string encode_environment(const Environment& e) {
  std::string bytes = "KENV";
  auto put = [&](uint32_t v) { bytes.append(reinterpret_cast<const char*>(&v), 4); };
  put(1);
  put(e.size);
  put(e.mips);
  for (const auto& c : e.sh) bytes.append(reinterpret_cast<const char*>(c.data()), 12);
  for (const auto& level : e.levels) bytes.append(reinterpret_cast<const char*>(level.data()), level.size() * 4);
  return bytes;
}

Environment load_environment(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  auto bad = [&](const std::string& m) { fail(DiagId::GoldenData, path, m); };
  if (!in) bad("cannot open the environment file (regenerate: kiln-reference environment -o FILE)");
  std::stringstream text;
  text << in.rdbuf();
  std::string bytes = text.str();
  if (bytes.size() < 16 + 108 || bytes.compare(0, 4, "KENV") != 0) bad("not a KENV environment");
  uint32_t header[3];
  std::memcpy(header, bytes.data() + 4, 12);
  if (header[0] != 1) bad("KENV version " + std::to_string(header[0]) + " (expected 1)");
  Environment e;
  e.size = header[1];
  e.mips = header[2];
  if (e.size == 0 || e.mips == 0 || e.mips > 16 || (e.size >> (e.mips - 1)) == 0) bad("bad KENV sizes");
  std::memcpy(e.sh.data(), bytes.data() + 16, 108);
  size_t offset = 16 + 108;
  for (uint32_t m = 0; m < e.mips; ++m) {
    size_t floats = size_t(6) * e.level_size(m) * e.level_size(m) * 4;
    if (bytes.size() < offset + floats * 4) bad("truncated KENV environment");
    e.levels.emplace_back(floats);
    std::memcpy(e.levels.back().data(), bytes.data() + offset, floats * 4);
    offset += floats * 4;
  }
  if (offset != bytes.size()) bad("trailing bytes after the KENV levels");
  return e;
}

}  // namespace kiln::render
