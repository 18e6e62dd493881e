// SPDX-License-Identifier: Apache-2.0
// Live pack updates (docs/reader.md, "Live updates"): PackReader::poll_update() and kiln_pack_poll_update() switch to
// a pack that a build wrote over the one they opened, say exactly which variants changed, refuse a damaged new pack
// and keep serving the old one, keep counting usage across the switch, and let select() run on other threads while
// they switch. No test waits on time: each one rebuilds, then polls.
#include <gtest/gtest.h>

#include <poll.h>

#include <atomic>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "kiln/kiln_reader.h"
#include "kiln/pack_format.hpp"
#include "kiln/pack_reader.hpp"
#include "common/files.hpp"
#include "pack/pack_writer.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

using Code = std::map<std::vector<std::string>, std::string>;  // keyword set -> its fragment stage's SPIR-V bytes

// Pack "live", pass P with groups {_, A, B} and {_, C}: one variant per entry of `code`, in its order (so indices
// follow the sorted keyword sets), each with its own fragment binary. Written as `kiln build` writes a pack: the
// archive, then the manifest renamed over the previous one.
std::filesystem::path write_live_pack(const std::filesystem::path& dir, const Code& code) {
  ArchiveBuilder archive;
  Manifest manifest;
  manifest.format_version = kPackFormatVersion;
  manifest.name = "live";
  manifest.reflections.emplace_back();
  ManifestPass& pass = manifest.passes.emplace_back();
  pass.name = "P";
  pass.entry_points[Stage::Fragment] = "F";
  pass.keyword_groups = {{"multi_compile", {"", "A", "B"}, kAllStageBits}, {"multi_compile", {"", "C"}, kAllStageBits}};
  for (const auto& [keywords, bytes] : code) {
    manifest.binaries.push_back({Stage::Fragment, "F", {{Target::Spirv, archive.add(bytes)}}, 0});
    pass.variants.push_back({keywords, {{Stage::Fragment, uint32_t(manifest.binaries.size() - 1)}}});
  }
  EXPECT_TRUE(write_pack(dir, "live", archive, manifest));
  return dir / "live.manifest.json";
}

std::string fragment_code(const SelectedVariant& variant) { return std::string(variant.stage("fragment")->spirv); }

// The archive the manifest in `dir` names.
std::filesystem::path archive_of(const std::filesystem::path& dir) {
  auto text = read_binary_file(dir / "live.manifest.json");
  return dir / nlohmann::json::parse(*text).at("archive").at("file").get<std::string>();
}

void flip_byte(const std::filesystem::path& file, size_t at) {
  std::string bytes = *read_binary_file(file);
  bytes[at] = static_cast<char>(bytes[at] ^ 0x5a);
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
}

const Code kFirst = {{{}, "spirv-0"}, {{"A"}, "spirv-A"}, {{"B"}, "spirv-B"}, {{"C"}, "spirv-C"}};
// [A] edited, [C] gone, [A C] new; [B] the same code, one index later ([A C] sorts before it).
const Code kSecond = {{{}, "spirv-0"}, {{"A"}, "spirv-A edited"}, {{"A", "C"}, "spirv-AC"}, {{"B"}, "spirv-B"}};

std::string describe(const std::vector<VariantChange>& changes) {
  static const char* kKinds[] = {"added", "changed", "removed", "moved"};
  std::string out;
  for (const VariantChange& change : changes) {
    out += std::string(kKinds[static_cast<int>(change.kind)]) + " " + change.pass + "[";
    for (const std::string& keyword : change.keywords) out += (out.back() == '[' ? "" : " ") + keyword;
    auto index = [](size_t i) { return i == VariantChange::kNoIndex ? std::string("-") : std::to_string(i); };
    out += "] " + index(change.old_index) + "->" + index(change.new_index) + "; ";
  }
  return out;
}

TEST(PackUpdate, APollSwitchesToTheRebuiltPackAndListsExactlyTheVariantsWhoseCodeChanged) {
  testing::TempDir dir;
  PackReader reader = PackReader::open(write_live_pack(dir.path(), kFirst));
  auto nothing = reader.poll_update();
  ASSERT_TRUE(nothing) << nothing.message();
  EXPECT_FALSE(nothing->switched);
  EXPECT_EQ(nothing->version, 1u);
  const SelectedVariant before = reader.select("P", {"A"});
  ASSERT_EQ(fragment_code(before), "spirv-A");

  write_live_pack(dir.path(), kSecond);
  auto update = reader.poll_update();
  ASSERT_TRUE(update) << update.message();
  EXPECT_TRUE(update->switched);
  EXPECT_EQ(update->version, 2u);
  EXPECT_EQ(update->archive, archive_of(dir.path()).filename().string());
  EXPECT_FALSE(update->ids_changed);  // the same pass and keywords
  EXPECT_EQ(describe(update->changes), "changed P[A] 1->1; added P[A C] -->2; moved P[B] 2->3; removed P[C] 3->-; ");

  // The new pack serves from now on; what select() returned before the switch is still readable until the next poll.
  EXPECT_EQ(fragment_code(reader.select("P", {"A"})), "spirv-A edited");
  EXPECT_EQ(fragment_code(reader.select("P", {"C", "A"})), "spirv-AC");
  EXPECT_EQ(reader.variant("P", 3).keywords, std::vector<std::string>{"B"});
  EXPECT_THROW(reader.select("P", {"C"}), PackError);
  EXPECT_EQ(fragment_code(before), "spirv-A");

  auto again = reader.poll_update();
  ASSERT_TRUE(again) << again.message();
  EXPECT_FALSE(again->switched);
  EXPECT_EQ(again->version, 2u);
  EXPECT_TRUE(again->changes.empty());
}

TEST(PackUpdate, APollWhenNothingChangedReadsNoFile) {
  testing::TempDir dir;
  PackReader reader = PackReader::open(write_live_pack(dir.path(), kFirst));
  std::filesystem::remove(archive_of(dir.path()));  // still mapped; a poll that read the pack again would miss it
  auto update = reader.poll_update();
  ASSERT_TRUE(update) << update.message();
  EXPECT_FALSE(update->switched);
  EXPECT_EQ(fragment_code(reader.select("P", {"B"})), "spirv-B");
}

TEST(PackUpdate, APackWrittenAgainWithTheSameBytesIsNoSwitch) {
  testing::TempDir dir;
  PackReader reader = PackReader::open(write_live_pack(dir.path(), kFirst));
  write_live_pack(dir.path(), kFirst);  // a new manifest file (another inode), the same pack
  auto update = reader.poll_update();
  ASSERT_TRUE(update) << update.message();
  EXPECT_FALSE(update->switched);
  EXPECT_EQ(update->version, 1u);
}

TEST(PackUpdate, ADamagedOrIncompleteNewPackIsRefusedOnceWithItsErrorAndTheOldPackKeepsServing) {
  testing::TempDir dir;
  PackReader reader = PackReader::open(write_live_pack(dir.path(), kFirst));

  // The new archive's runtime index damaged after the build: its head checksum fails.
  write_live_pack(dir.path(), kSecond);
  flip_byte(archive_of(dir.path()), kPackHeaderSize + 4);
  auto refused = reader.poll_update();
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.code(), PackError::Code::Checksum) << refused.message();
  EXPECT_EQ(refused.file(), archive_of(dir.path()).string());
  EXPECT_EQ(fragment_code(reader.select("P", {"A"})), "spirv-A");
  EXPECT_EQ(fragment_code(reader.select("P", {"C"})), "spirv-C");
  auto reported = reader.poll_update();  // reported once: the same files are not read again
  ASSERT_TRUE(reported) << reported.message();
  EXPECT_FALSE(reported->switched);

  // A manifest whose archive is not there (copied in the wrong order, or removed).
  write_live_pack(dir.path(), kSecond);
  std::filesystem::remove(archive_of(dir.path()));
  auto missing = reader.poll_update();
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.code(), PackError::Code::Io) << missing.message();
  EXPECT_EQ(fragment_code(reader.select("P", {"A"})), "spirv-A");

  // The next good build is taken.
  write_live_pack(dir.path(), kSecond);
  auto good = reader.poll_update();
  ASSERT_TRUE(good) << good.message();
  EXPECT_TRUE(good->switched);
  EXPECT_EQ(fragment_code(reader.select("P", {"A"})), "spirv-A edited");
}

TEST(PackUpdate, UsageRecordingCountsSelectionsFromBeforeAndAfterTheSwitchByKeywordSet) {
  testing::TempDir dir;
  PackReader reader = PackReader::open(write_live_pack(dir.path(), kFirst));
  reader.record_usage({dir / "usage.json", {}});
  for (int i = 0; i < 3; ++i) reader.select("P", {"A"});
  reader.select("P", {"C"});
  write_live_pack(dir.path(), kSecond);
  ASSERT_TRUE(reader.poll_update()->switched);
  reader.select("P", {"A"});
  reader.select("P", {"A"});
  reader.note_selected(0, 3);  // the C API's count by ids: [B] is variant 3 of the new pack
  // Two more polls free the replaced version, folding its counts into the log's.
  ASSERT_TRUE(reader.poll_update());
  ASSERT_TRUE(reader.poll_update());
  auto sets = reader.flush_usage();
  ASSERT_TRUE(sets) << sets.message();
  EXPECT_EQ(*sets, 3u);
  const auto log = nlohmann::json::parse(*read_binary_file(dir / "usage.json"));
  std::map<std::vector<std::string>, uint64_t> served;
  for (const auto& entry : log.at("passes").at(0).at("served"))
    served[entry.at("keywords").get<std::vector<std::string>>()] = entry.at("count").get<uint64_t>();
  EXPECT_EQ(served, (std::map<std::vector<std::string>, uint64_t>{{{"A"}, 5}, {{"B"}, 1}, {{"C"}, 1}}));
}

// Correctness only: a thread selects without pause while the main thread rebuilds and polls; every selection is one
// pack's, whole (the code of its keyword set in some build, never an older build after a newer one), its views stay
// readable while the thread holds a Pin, and versions replaced are freed while it runs (a use after free crashes
// here, and asan names it).
TEST(PackUpdate, SelectOnAnotherThreadSeesOnePackWholeWhileThePollSwitches) {
  testing::TempDir dir;
  auto build = [&](int round) {
    return Code{{{}, "spirv-0 " + std::to_string(round)}, {{"A"}, "spirv-A " + std::to_string(round)}};
  };
  PackReader reader = PackReader::open(write_live_pack(dir.path(), build(0)));
  constexpr int kRounds = 40;
  std::atomic<bool> done{false};
  std::atomic<int> selections{0};
  std::string failure;
  std::thread selector([&] {
    int newest = 0;
    while (!done.load(std::memory_order_acquire) || selections.load() < 100) {
      const PackReader::Pin pin = reader.pin();  // the views below are read after select() returns
      const SelectedVariant variant = reader.select("P", {"A"});
      const std::string code = fragment_code(variant);
      const int round = code.rfind("spirv-A ", 0) == 0 ? std::stoi(code.substr(8)) : -1;
      if (round < newest || round > kRounds || variant.keywords != std::vector<std::string>{"A"}) {
        failure = "selected '" + code + "' after round " + std::to_string(newest);
        return;
      }
      newest = round;
      selections.fetch_add(1);
    }
  });
  for (int round = 1; round <= kRounds; ++round) {
    write_live_pack(dir.path(), build(round));
    auto update = reader.poll_update();
    ASSERT_TRUE(update && update->switched) << round;
    EXPECT_EQ(describe(update->changes), "changed P[] 0->0; changed P[A] 1->1; ");
    ASSERT_TRUE(reader.poll_update());  // frees the version before, once the selector is out of it
  }
  done.store(true, std::memory_order_release);
  selector.join();
  EXPECT_EQ(failure, "");
  EXPECT_EQ(fragment_code(reader.select("P", {"A"})), "spirv-A " + std::to_string(kRounds));
}

TEST(PackUpdate, TheUpdateFdBecomesReadableWhenABuildReplacesThePackAndThePollDrainsIt) {
  testing::TempDir dir;
  PackReader reader = PackReader::open(write_live_pack(dir.path(), kFirst));
  auto fd = reader.update_fd();
  ASSERT_TRUE(fd) << fd.message();
  EXPECT_EQ(*reader.update_fd(), *fd);
  pollfd wait{*fd, POLLIN, 0};
  ASSERT_EQ(::poll(&wait, 1, 0), 0);  // nothing yet
  write_live_pack(dir.path(), kSecond);
  ASSERT_EQ(::poll(&wait, 1, 60'000), 1);  // readable now; the limit only bounds a broken test
  auto update = reader.poll_update();
  ASSERT_TRUE(update && update->switched);
  wait.revents = 0;
  EXPECT_EQ(::poll(&wait, 1, 0), 0);  // drained
}

// The C API: the same switch, with pass ids and variant indices on both sides, the code bytes handed out before the
// switch still readable until the next poll, and a refused pack leaving the old one serving.
TEST(PackUpdate, TheCApiSwitchesListsChangesWithIdsAndIndicesAndRefusesADamagedPack) {
  testing::TempDir dir;
  write_live_pack(dir.path(), kFirst);
  kiln_error error;
  kiln_pack* pack = nullptr;
  ASSERT_EQ(kiln_pack_open(dir.path().c_str(), &pack, &error), KILN_OK) << error.message;
  kiln_pass pass = 0;
  kiln_keyword a = 0;
  ASSERT_EQ(kiln_pass_find(pack, "P", &pass, &error), KILN_OK);
  ASSERT_EQ(kiln_keyword_find(pack, "A", &a, &error), KILN_OK);
  auto code_of = [&](uint32_t variant) {
    kiln_code code{};
    EXPECT_EQ(kiln_variant_code(pack, pass, variant, KILN_STAGE_FRAGMENT, KILN_TARGET_SPIRV, &code, &error), KILN_OK);
    return code;
  };
  uint32_t variant = 0;
  ASSERT_EQ(kiln_select(pack, pass, &a, 1, 0, &variant, &error), KILN_OK);
  const kiln_code before = code_of(variant);

  kiln_pack_update update;
  ASSERT_EQ(kiln_pack_poll_update(pack, &update, &error), KILN_OK) << error.message;
  EXPECT_EQ(update.switched, 0);
  EXPECT_EQ(update.change_count, 0u);

  write_live_pack(dir.path(), kSecond);
  ASSERT_EQ(kiln_pack_poll_update(pack, &update, &error), KILN_OK) << error.message;
  EXPECT_EQ(update.switched, 1);
  EXPECT_EQ(update.ids_changed, 0);
  EXPECT_EQ(update.version, 2u);
  EXPECT_EQ(std::string(update.archive), archive_of(dir.path()).filename().string());
  std::string changes;
  for (size_t i = 0; i < update.change_count; ++i) {
    const kiln_variant_change& c = update.changes[i];
    changes += std::to_string(c.kind) + " " + c.pass + " " + std::to_string(c.old_pass) + "/" + std::to_string(c.new_pass) + " " +
               (c.old_variant == KILN_NO_INDEX ? "-" : std::to_string(c.old_variant)) + "->" +
               (c.new_variant == KILN_NO_INDEX ? "-" : std::to_string(c.new_variant)) + " [";
    for (uint32_t k = 0; k < c.keyword_count; ++k) changes += std::string(k ? " " : "") + c.keywords[k];
    changes += "]; ";
  }
  EXPECT_EQ(changes, "2 P 0/0 1->1 [A]; 1 P 0/0 -->2 [A C]; 4 P 0/0 2->3 [B]; 3 P 0/0 3->- [C]; ");
  EXPECT_EQ(std::string(static_cast<const char*>(before.bytes), before.size), "spirv-A");  // until the next poll
  ASSERT_EQ(kiln_select(pack, pass, &a, 1, 0, &variant, &error), KILN_OK);
  const kiln_code after = code_of(variant);
  EXPECT_EQ(std::string(static_cast<const char*>(after.bytes), after.size), "spirv-A edited");
  EXPECT_EQ(kiln_variant_count(pack, pass), 4u);

  // A damaged new pack: the error, nothing switched, the pack as it was.
  write_live_pack(dir.path(), kFirst);
  flip_byte(archive_of(dir.path()), kPackHeaderSize + 4);
  EXPECT_EQ(kiln_pack_poll_update(pack, &update, &error), KILN_ERROR_CHECKSUM);
  EXPECT_EQ(std::string(error.file), archive_of(dir.path()).string());
  EXPECT_EQ(update.switched, 0);
  EXPECT_EQ(update.change_count, 0u);
  ASSERT_EQ(kiln_select(pack, pass, &a, 1, 0, &variant, &error), KILN_OK);
  const kiln_code still = code_of(variant);
  EXPECT_EQ(std::string(static_cast<const char*>(still.bytes), still.size), "spirv-A edited");

  EXPECT_EQ(kiln_pack_poll_update(nullptr, &update, &error), KILN_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(kiln_pack_poll_update(pack, nullptr, &error), KILN_ERROR_INVALID_ARGUMENT);
  kiln_pack_close(pack);
}

}  // namespace
}  // namespace kiln
