// SPDX-License-Identifier: Apache-2.0
// unit.capi.UsageRecordingCountsEverySelectionFromEveryThread: the readers' usage log (docs/usage.md). Four threads
// select through the C++ reader and the C API at once; the log holds exactly the counts asked for, the keyword set
// the pack lacks with its nearest variant, the tags, and the pack's name; a reader that goes writes its log; more
// missing sets than the bound are counted, not kept; a log that cannot be written is an error, not a crash.
// usage: usage_test <pack dir> <scratch dir>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "kiln/kiln_reader.h"
#include "checks.hpp"
#include "kiln/pack_reader.hpp"

namespace {


nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()));
}

// The count of `keywords` in `pass`'s list `what` ("served" or "missing") of the log; 0 when absent.
uint64_t count_of(const nlohmann::json& log, const std::string& pass, const char* what, const std::vector<std::string>& keywords) {
  for (const auto& p : log.at("passes"))
    if (p.at("name") == pass)
      for (const auto& entry : p.at(what))
        if (entry.at("keywords").get<std::vector<std::string>>() == keywords) return entry.at("count").get<uint64_t>();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) return 2;
  const std::string pack_dir = argv[1], scratch = argv[2];
  const std::string log_file = scratch + "/usage.json";
  std::remove(log_file.c_str());
  {
    kiln::PackReader reader = kiln::PackReader::open(pack_dir);
    kiln_pack* pack = nullptr;
    kiln_error error;
    CHECK(kiln_pack_open(pack_dir.c_str(), &pack, &error) == KILN_OK);
    reader.record_usage({log_file, {{"scene", "forest"}, {"build", "1.4"}}});
    const char* tags[] = {"scene=forest"};
    CHECK(kiln_pack_record_usage(pack, (scratch + "/c-usage.json").c_str(), tags, 1, &error) == KILN_OK);
    const char* bad_tag[] = {"no-equals-sign"};
    CHECK(kiln_pack_record_usage(pack, (scratch + "/c-usage.json").c_str(), bad_tag, 1, &error) == KILN_ERROR_INVALID_ARGUMENT);

    kiln_pass main_pass = 0;
    kiln_keyword low = 0, fog = 0;
    CHECK(kiln_pass_find(pack, "Main", &main_pass, &error) == KILN_OK);
    CHECK(kiln_keyword_find(pack, "QUALITY_LOW", &low, &error) == KILN_OK);
    CHECK(kiln_keyword_find(pack, "FOG", &fog, &error) == KILN_OK);
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
      threads.emplace_back([&] {
        for (int i = 0; i < 1000; ++i) reader.select("Main", {"QUALITY_LOW"});
        for (int i = 0; i < 10; ++i) reader.select("Main", {"FOG", "QUALITY_HIGH", "NOT_DECLARED_HERE"});
        for (int i = 0; i < 3; ++i) static_cast<void>(reader.try_select("Main", {"FOG", "TINT", "QUALITY_LOW"}));
        const kiln_keyword ids[] = {fog, low};
        uint32_t variant = 0;
        kiln_error own;
        for (int i = 0; i < 500; ++i) kiln_select(pack, main_pass, ids, 2, 0, &variant, &own);  // the C API's fast path
      });
    for (std::thread& thread : threads) thread.join();
    reader.select("Depth", {});

    auto written = reader.flush_usage();
    CHECK(written && *written == 4);  // two served sets of Main, one of Depth, and one missing set of Main
    const nlohmann::json log = read_json(log_file);
    CHECK(log.at("format") == "kiln-usage");
    CHECK(log.at("format_version") == 1);
    CHECK(log.at("pack") == "tiny");
    CHECK(log.at("tags") == nlohmann::json({{"scene", "forest"}, {"build", "1.4"}}));
    CHECK(count_of(log, "Main", "served", {"QUALITY_LOW"}) == 4000);
    CHECK(count_of(log, "Main", "served", {"FOG", "QUALITY_HIGH"}) == 40);  // a keyword the pass lacks is ignored
    CHECK(count_of(log, "Main", "missing", {"FOG", "QUALITY_LOW", "TINT"}) == 12);
    CHECK(count_of(log, "Depth", "served", {}) == 1);
    CHECK(log.at("missing_dropped") == 0);
    for (const auto& p : log.at("passes"))
      for (const auto& m : p.at("missing")) CHECK(m.at("nearest") == nlohmann::json({"FOG", "QUALITY_LOW"}));
    // The C API's own pack counted its selections, not the C++ reader's.
    CHECK(kiln_pack_flush_usage(pack, &error) == KILN_OK);
    const nlohmann::json c_log = read_json(scratch + "/c-usage.json");
    CHECK(count_of(c_log, "Main", "served", {"FOG", "QUALITY_LOW"}) == 2000);
    CHECK(count_of(c_log, "Main", "served", {"QUALITY_LOW"}) == 0);
    CHECK(c_log.at("tags") == nlohmann::json({{"scene", "forest"}}));
    kiln_pack_close(pack);

    // Selections after a flush keep counting; the reader's end writes the log again.
    reader.select("Main", {"QUALITY_LOW"});
  }
  CHECK(count_of(read_json(log_file), "Main", "served", {"QUALITY_LOW"}) == 4001);

  // At most max_missing distinct missing sets are kept; the rest are counted.
  {
    kiln::PackReader reader = kiln::PackReader::open(pack_dir);
    reader.record_usage({scratch + "/bounded.json", {}, 1});
    static_cast<void>(reader.try_select("Main", {"FOG", "TINT", "QUALITY_LOW"}));
    static_cast<void>(reader.try_select("Main", {"FOG", "TINT", "QUALITY_HIGH"}));
    CHECK(static_cast<bool>(reader.flush_usage()));
    const nlohmann::json log = read_json(scratch + "/bounded.json");
    CHECK(log.at("missing_dropped") == 1);
    CHECK(log.at("passes").at(0).at("missing").size() == 1);

    // A log that cannot be written: an error with the file, nothing thrown; not recording: nothing to write.
    reader.record_usage({scratch + "/no-such-dir/usage.json", {}});
    auto failed = reader.flush_usage();
    CHECK(!failed && failed.code() == kiln::PackError::Code::Io && failed.file() == scratch + "/no-such-dir/usage.json");
    reader.record_usage({scratch + "/bounded.json", {}});
  }
  {
    kiln::PackReader quiet = kiln::PackReader::open(pack_dir);
    auto nothing = quiet.flush_usage();
    CHECK(nothing && *nothing == 0);
  }
  return kiln::checks::result();
}
