// SPDX-License-Identifier: Apache-2.0
// kiln-synthetic-pack PACK SCALE OUT_DIR: writes pack `<name>x<SCALE>` to OUT_DIR, SCALE copies of PACK's passes
// (named `<pass>_<copy>`), each with its own binaries and blobs (every blob's bytes with the copy's number
// appended, so that none is deduplicated away), through kiln's own writer: a pack SCALE times larger in variants,
// archive and index, for bench/pack_open.sh. The bytes are no valid shaders; the reader does not look inside them.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "kiln/pack_reader.hpp"
#include "pack/pack_writer.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: kiln-synthetic-pack PACK SCALE OUT_DIR\n");
    return 2;
  }
  const kiln::PackReader pack = kiln::PackReader::open(argv[1], kiln::PackReader::Check::Full);
  const kiln::Manifest& source = pack.manifest();
  const int scale = std::atoi(argv[2]);
  kiln::Manifest out = source;
  out.name = source.name + "x" + std::to_string(scale);
  out.passes.clear();
  out.binaries.clear();
  kiln::ArchiveBuilder archive;
  for (int copy = 0; copy < scale; ++copy) {
    const auto first_binary = static_cast<uint32_t>(out.binaries.size());
    for (kiln::ManifestBinary binary : source.binaries) {
      for (auto& [target, blob] : binary.blobs) {
        std::string bytes(pack.blob(blob));
        bytes += "copy " + std::to_string(copy);
        blob = archive.add(bytes);
      }
      out.binaries.push_back(binary);
    }
    for (kiln::ManifestPass pass : source.passes) {
      pass.name += "_" + std::to_string(copy);
      for (kiln::ManifestVariant& variant : pass.variants)
        for (auto& [stage, binary] : variant.binaries) binary += first_binary;
      out.passes.push_back(pass);
    }
  }
  std::filesystem::create_directories(argv[3]);
  const kiln::Result<std::string> written = kiln::write_pack(argv[3], out.name, archive, out);
  if (!written) {
    std::fprintf(stderr, "kiln-synthetic-pack: %s\n", written.error().message.c_str());
    return 1;
  }
  std::printf("%s/%s.manifest.json\n", argv[3], out.name.c_str());
  return 0;
}
