// SPDX-License-Identifier: Apache-2.0
// The C API (kiln_reader.h) against the C++ reader it wraps, on hand-made packs with the awkward cases: a group
// without an off value, a one-keyword group, a keyword in two groups, stripped combinations, a compressed blob.
// tests/capi/ has the tests in C and in C++ without exceptions.
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
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

// Pass P folds an int group {_, A, B} and a dynamic-branch group {_, C} beside a multi_compile {_, M}; pass Q folds
// one int group of 70,000 values (a forged group of that size took kiln_variant_value a minute to read in full).
std::filesystem::path write_folded_pack(const testing::TempDir& dir) {
  ArchiveBuilder archive;
  Manifest manifest;
  manifest.format_version = kPackFormatVersion;
  manifest.name = "folded";
  manifest.reflections.emplace_back();
  manifest.binaries.push_back({Stage::Fragment, "F", {{Target::Spirv, archive.add("SPIRV")}}, 0});
  ManifestPass& p = manifest.passes.emplace_back();
  p.name = "P";
  p.entry_points[Stage::Fragment] = "F";
  p.keyword_groups = {{"specialization_constant_int", {"", "A", "B"}, kAllStageBits},
                      {"dynamic_branch_fragment", {"", "C"}, stage_bit(Stage::Fragment)},
                      {"multi_compile", {"", "M"}, kAllStageBits}};
  for (std::string g0 : {"", "A", "B"})
    for (std::string g1 : {"", "C"})
      for (std::string g2 : {"", "M"}) {
        std::vector<std::string> keywords;
        for (const std::string& k : {g0, g1, g2})
          if (!k.empty()) keywords.push_back(k);
        std::sort(keywords.begin(), keywords.end());
        p.variants.push_back({keywords, {{Stage::Fragment, 0}}});
      }
  ManifestPass& q = manifest.passes.emplace_back();
  q.name = "Q";
  q.entry_points[Stage::Fragment] = "F";
  ManifestKeywordGroup& many = q.keyword_groups.emplace_back(ManifestKeywordGroup{"specialization_constant_int", {""}, kAllStageBits});
  for (int k = 1; k < 70000; ++k) many.values.push_back("K" + std::to_string(k));
  q.variants.push_back({{}, {{Stage::Fragment, 0}}});
  q.variants.push_back({{"K69999"}, {{Stage::Fragment, 0}}});
  EXPECT_TRUE(write_pack(dir.path(), "folded", archive, manifest));
  return dir / "folded.manifest.json";
}

TEST(CApi, AVariantsFoldedValuesAtOnceAreTheOnesEachValueCallAndTheCppReaderGive) {
  testing::TempDir dir;
  const std::filesystem::path path = write_folded_pack(dir);
  PackReader reader = PackReader::open(path);
  CPack c(path);
  ASSERT_EQ(kiln_pass_value_count(c.pack, 0), 4u);  // _, A, B, C
  for (uint32_t v = 0; v < kiln_variant_count(c.pack, 0); ++v) {
    const SelectedVariant cpp = reader.variant("P", v);
    kiln_keyword_value all[4];
    ASSERT_EQ(kiln_variant_values(c.pack, 0, v, all, 4, nullptr), KILN_OK);
    for (uint32_t i = 0; i < 4; ++i) {
      kiln_keyword_value one{};
      ASSERT_EQ(kiln_variant_value(c.pack, 0, v, i, &one, nullptr), KILN_OK);
      EXPECT_STREQ(all[i].keyword, one.keyword);
      EXPECT_EQ(all[i].keyword, cpp.values[i].keyword);
      EXPECT_EQ(all[i].kind, one.kind);
      EXPECT_EQ(all[i].stage_flags, one.stage_flags);
      EXPECT_EQ(all[i].slot, one.slot);
      EXPECT_EQ(all[i].slot, cpp.values[i].slot);
      EXPECT_EQ(all[i].on, one.on);
      EXPECT_EQ(all[i].on != 0, cpp.values[i].on) << "variant " << v << " value " << i;
      EXPECT_EQ(all[i].value, one.value);
      EXPECT_EQ(all[i].value, cpp.values[i].data());
    }
  }
  kiln_keyword_value three[3];
  kiln_error error;
  EXPECT_EQ(kiln_variant_values(c.pack, 0, 0, three, 3, &error), KILN_ERROR_INVALID_ARGUMENT);
  EXPECT_STREQ(error.message, "kiln_variant_values: pass 0 has 4 folded keywords, room for 3");
  EXPECT_EQ(kiln_variant_values(c.pack, 0, 12, three, 4, &error), KILN_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(kiln_variant_values(c.pack, 0, 0, nullptr, 4, &error), KILN_ERROR_INVALID_ARGUMENT);

  // 70,000 values in one call: exactly one is on, the variant's.
  ASSERT_EQ(kiln_pass_value_count(c.pack, 1), 70000u);
  std::vector<kiln_keyword_value> many(70000);
  ASSERT_EQ(kiln_variant_values(c.pack, 1, 1, many.data(), 70000, &error), KILN_OK) << error.message;
  EXPECT_EQ(std::count_if(many.begin(), many.end(), [](const kiln_keyword_value& k) { return k.on != 0; }), 1);
  EXPECT_STREQ(many.back().keyword, "K69999");
  EXPECT_EQ(many.back().on, 1u);
  EXPECT_EQ(many.back().value, 69999u);
  ASSERT_EQ(kiln_variant_values(c.pack, 1, 0, many.data(), 70000, &error), KILN_OK);
  EXPECT_EQ(many.front().on, 1u);  // the off value
}

// The child of AnOpenOfTwentyThousandPassesEachWithItsOwnKeywordFitsInTheMemoryItReads: opens the pack under a 2 GiB
// address-space limit, selects in its last pass, and prints what it got. It ends with _Exit, so it first removes
// its own copy of `dir` (the test body ran again in the child).
[[noreturn]] void open_and_select_within_limits(const testing::TempDir& dir) {
#if !defined(__SANITIZE_ADDRESS__)  // ASan reserves terabytes of shadow memory: no address-space limit there
  const rlimit limit{uint64_t{2} << 30, uint64_t{2} << 30};
  ::setrlimit(RLIMIT_AS, &limit);
#endif
  kiln_error error{};
  kiln_pack* pack = nullptr;
  const kiln_result opened = kiln_pack_open((dir / "wide.manifest.json").c_str(), &pack, &error);
  kiln_keyword keyword = 0;
  uint32_t variant = 99;
  if (opened == KILN_OK && kiln_keyword_find(pack, "K19999", &keyword, &error) == KILN_OK)
    kiln_select(pack, kiln_pass_count(pack) - 1, &keyword, 1, 1, &variant, &error);
  std::fprintf(stderr, "open %s, variant %u: %s\n", kiln_result_name(opened), variant, error.message);
  kiln_pack_close(pack);
  std::error_code ec;
  std::filesystem::remove_all(dir.path(), ec);
  std::_Exit(0);
}

// kiln_pack_open's selection tables were one entry per pack keyword for every pass: 20,000 passes of a keyword each
// (a 2 MB index) asked for 3.2 GB, 100,000 for 80 GB. They are as long as each pass's own groups now.
TEST(CApi, AnOpenOfTwentyThousandPassesEachWithItsOwnKeywordFitsInTheMemoryItReads) {
  testing::TempDir dir;
  ArchiveBuilder archive;
  Manifest manifest;
  manifest.format_version = kPackFormatVersion;
  manifest.name = "wide";
  manifest.reflections.emplace_back();
  manifest.binaries.push_back({Stage::Fragment, "F", {{Target::Spirv, archive.add("SPIRV")}}, 0});
  for (int p = 0; p < 20000; ++p) {
    ManifestPass& pass = manifest.passes.emplace_back();
    pass.name = "P" + std::to_string(p);
    pass.entry_points[Stage::Fragment] = "F";
    pass.keyword_groups = {{"multi_compile", {"", "K" + std::to_string(p)}, kAllStageBits}};
    pass.variants = {{{}, {{Stage::Fragment, 0}}}, {{"K" + std::to_string(p)}, {{Stage::Fragment, 0}}}};
  }
  ASSERT_TRUE(write_pack(dir.path(), "wide", archive, manifest));
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(open_and_select_within_limits(dir), ::testing::ExitedWithCode(0),
              "open ok, variant 1: \n");
}

}  // namespace
}  // namespace kiln
