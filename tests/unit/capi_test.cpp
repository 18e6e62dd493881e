// The C API (kiln_reader.h) against the C++ reader it wraps, on hand-made packs with the awkward cases: a group
// without an off value, a one-keyword group, a keyword in two groups, stripped combinations, a compressed blob.
// tests/capi/ has the tests in C and in C++ without exceptions.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "kiln/kiln_reader.h"
#include "kiln/pack_format.hpp"
#include "kiln/pack_reader.hpp"
#include "pack/pack_writer.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

const std::string kLongText = [] {
  std::string text;
  for (int i = 0; i < 64; ++i) text += "float3 light" + std::to_string(i) + " = normalize(L - P);\n";
  return text;  // compressible: stored as a zstd frame
}();

// Pass P: groups {_, A, B}, {C, D} (no off value), {E} (always on), {_, B, F} (B is also in the first group, which
// takes it); every combination but those with A and F together. Pass Q: {_, X}.
std::filesystem::path write_awkward_pack(const testing::TempDir& dir) {
  ArchiveBuilder archive;
  Manifest manifest;
  manifest.format_version = kPackFormatVersion;
  manifest.name = "awkward";
  manifest.reflections.emplace_back();
  auto add_binaries = [&](const std::string& tag) {
    manifest.binaries.push_back({Stage::Vertex, "V", {{Target::Spirv, archive.add("SPIRV " + tag)}}, 0});
    manifest.binaries.push_back({Stage::Fragment, "F",
                                 {{Target::Spirv, archive.add("SPIRV-F " + tag)}, {Target::Glsl, archive.add("#version 450 // " + tag)},
                                  {Target::Msl, archive.add(kLongText + tag)}},
                                 0});
    return std::map<Stage, uint32_t>{{Stage::Vertex, uint32_t(manifest.binaries.size() - 2)},
                                      {Stage::Fragment, uint32_t(manifest.binaries.size() - 1)}};
  };
  ManifestPass& p = manifest.passes.emplace_back();
  p.name = "P";
  p.keyword_groups = {{"multi_compile", {"", "A", "B"}, kAllStageBits},
                      {"multi_compile", {"C", "D"}, kAllStageBits},
                      {"multi_compile", {"E"}, kAllStageBits},
                      {"multi_compile_fragment", {"", "B", "F"}, kAllStageBits}};
  for (std::string g0 : {"", "A", "B"})
    for (std::string g1 : {"C", "D"})
      for (std::string g3 : {"", "B", "F"}) {
        if ((g0 == "A" && g3 == "F") || (g0 == "B" && g3 == "B")) continue;
        std::vector<std::string> keywords{g1, "E"};
        for (const std::string& k : {g0, g3})
          if (!k.empty()) keywords.push_back(k);
        std::sort(keywords.begin(), keywords.end());
        std::string tag;
        for (const std::string& k : keywords) tag += k;
        p.variants.push_back({keywords, add_binaries(tag)});
      }
  ManifestPass& q = manifest.passes.emplace_back();
  q.name = "Q";
  q.keyword_groups = {{"multi_compile", {"", "X"}, kAllStageBits}};
  q.variants.push_back({{}, add_binaries("Q")});
  q.variants.push_back({{"X"}, add_binaries("QX")});
  EXPECT_TRUE(write_pack(dir.path(), "awkward", archive, manifest));
  return dir / "awkward.manifest.json";
}

struct Outcome {
  kiln_result code = KILN_OK;
  std::string message;
  uint32_t variant = 0;
  friend bool operator==(const Outcome&, const Outcome&) = default;
};
std::ostream& operator<<(std::ostream& out, const Outcome& o) {
  return out << kiln_result_name(o.code) << " " << o.variant << " " << o.message;
}

struct CPack {
  kiln_pack* pack = nullptr;
  explicit CPack(const std::filesystem::path& path) {
    kiln_error error;
    EXPECT_EQ(kiln_pack_open(path.c_str(), &pack, &error), KILN_OK) << error.message;
  }
  ~CPack() { kiln_pack_close(pack); }
};

TEST(CApi, SelectionByIdsAndByNamesAgreeWithTheCppReaderOnEveryKeywordSet) {
  testing::TempDir dir;
  const std::filesystem::path path = write_awkward_pack(dir);
  PackReader reader = PackReader::open(path);
  CPack c(path);
  const std::vector<std::string> all{"A", "B", "C", "D", "E", "F", "X"};
  ASSERT_EQ(kiln_keyword_count(c.pack), all.size());
  int selected = 0;
  for (kiln_pass pass = 0; pass < 2; ++pass) {
    const std::string pass_name = kiln_pass_name(c.pack, pass);
    for (unsigned subset = 0; subset < (1u << all.size()); ++subset)
      for (int strict = 0; strict < 2; ++strict) {
        std::vector<std::string> names;
        std::vector<kiln_keyword> ids;
        std::vector<const char*> pointers;
        for (size_t k = 0; k < all.size(); ++k)
          if (subset & (1u << k)) {
            names.push_back(all[k]);
            kiln_keyword id = 0;
            ASSERT_EQ(kiln_keyword_find(c.pack, all[k].c_str(), &id, nullptr), KILN_OK);
            ids.push_back(id);
            ids.push_back(id);  // repeated: harmless, as in the C++ reader
          }
        for (const std::string& n : names) pointers.push_back(n.c_str());
        Outcome cpp;
        try {
          cpp.variant = static_cast<uint32_t>(reader.select(pass_name, names, strict != 0).index);
          ++selected;
        } catch (const PackError& e) {
          cpp.code = static_cast<kiln_result>(static_cast<int>(e.code()) + 1);
          cpp.message = e.what();
        }
        kiln_error error;
        Outcome by_ids, by_names;
        by_ids.code = kiln_select(c.pack, pass, ids.data(), ids.size(), strict, &by_ids.variant, &error);
        by_ids.message = error.message;
        if (by_ids.code != KILN_OK) by_ids.variant = 0;
        by_names.code = kiln_select_by_names(c.pack, pass_name.c_str(), pointers.data(), pointers.size(), strict,
                                             &by_names.variant, &error);
        by_names.message = error.message;
        if (by_names.code != KILN_OK) by_names.variant = 0;
        EXPECT_EQ(by_ids, cpp) << pass_name << " subset " << subset << " strict " << strict;
        EXPECT_EQ(by_names, cpp) << pass_name << " subset " << subset << " strict " << strict;
      }
  }
  EXPECT_GT(selected, 100);  // the sets cover successes as well as every error
}

TEST(CApi, CodeIsTheBytesTheCppReaderReturns) {
  testing::TempDir dir;
  const std::filesystem::path path = write_awkward_pack(dir);
  PackReader reader = PackReader::open(path);
  CPack c(path);
  for (kiln_pass pass = 0; pass < kiln_pass_count(c.pack); ++pass)
    for (uint32_t v = 0; v < kiln_variant_count(c.pack, pass); ++v) {
      SelectedVariant cpp = reader.variant(kiln_pass_name(c.pack, pass), v);
      for (kiln_stage stage : {KILN_STAGE_VERTEX, KILN_STAGE_FRAGMENT}) {
        const StageView* view = cpp.stage(stage_name(static_cast<Stage>(stage)));
        ASSERT_NE(view, nullptr);
        EXPECT_EQ(kiln_variant_entry_point(c.pack, pass, v, stage), view->entry_point);
        for (int target = KILN_TARGET_SPIRV; target < KILN_TARGET_COUNT; ++target) {
          kiln_code code{};
          ASSERT_EQ(kiln_variant_code(c.pack, pass, v, stage, static_cast<kiln_target>(target), &code, nullptr), KILN_OK);
          EXPECT_EQ(std::string_view(static_cast<const char*>(code.bytes), code.size), view->code(static_cast<Target>(target)))
              << "pass " << pass << " variant " << v << " stage " << stage << " target " << target;
        }
      }
    }
}

TEST(CApi, AnOpenFailureIsTheCppReadersCodeMessageAndFile) {
  testing::TempDir dir;
  const std::filesystem::path path = write_awkward_pack(dir);
  std::filesystem::remove(dir / PackReader::open(path).manifest().archive.file);
  kiln_error error;
  kiln_pack* pack = nullptr;
  EXPECT_EQ(kiln_pack_open(path.c_str(), &pack, &error), KILN_ERROR_IO);
  EXPECT_EQ(pack, nullptr);
  try {
    PackReader::open(path);
    ADD_FAILURE() << "opened a pack without its archive";
  } catch (const PackError& e) {
    EXPECT_STREQ(error.message, e.what());
    EXPECT_EQ(error.file, e.file());
  }
}

}  // namespace
}  // namespace kiln
