// SPDX-License-Identifier: Apache-2.0
// kiln watch (docs/development-loop.md), run as a user runs it: in the background, edited under it, its status lines
// read from a pipe. Every wait is on an event (a status line, an inotify event in the output directory), never on
// time; the packs are tiny (three variants of one pass) so that each round costs little.
#include <gtest/gtest.h>
#include <sys/inotify.h>
#include <sys/stat.h>

#include <map>

#include <nlohmann/json.hpp>

#include "test_support.hpp"
#include "usage_log_text.hpp"

namespace kiln {
namespace {

const char* kPack = R"({"name": "p", "include_dirs": ["lib"], "budget": 64,
  "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})";

// Three variants; the fragment stage of each returns a different multiple of colour().
std::string shader(const std::string& a_factor = "2.0", const std::string& b_code = "return colour() * 3.0;") {
  return "#pragma multi_compile _ A B\n#include \"Colour.hlsl\"\n"
         "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
         "float4 F() : SV_Target {\n#if defined(A)\n  return colour() * " + a_factor + ";\n#elif defined(B)\n  " + b_code +
         "\n#else\n  return colour();\n#endif\n}\n";
}
std::string colour(const std::string& value) { return "float4 colour() { return " + value + "; }\n"; }

using testing::usage_log;

struct Watch : ::testing::Test {
  testing::TempDir dir;
  std::unique_ptr<testing::BackgroundProcess> kiln;

  void SetUp() override {
    dir.write("p.pack.json", kPack);
    dir.write("S.hlsl", shader());
    dir.write("lib/Colour.hlsl", colour("0.25"));
  }
  void start(std::vector<std::string> extra = {}) {
    std::vector<std::string> args{KILN_CLI_PATH, "watch", "p.pack.json", "-o", "out", "--cache", "cache", "-j", "1"};
    args.insert(args.end(), extra.begin(), extra.end());
    kiln = std::make_unique<testing::BackgroundProcess>(args, dir.path());
  }
  // The next status line (each round writes one), failing the test when watch ended instead.
  std::string status() {
    std::optional<std::string> line = kiln->next_line();
    EXPECT_TRUE(line) << "kiln watch ended or wrote nothing; its stderr:\n" << kiln->err();
    return line.value_or("");
  }
  // An editor's save: the new text written to a temporary file beside the old one and renamed over it.
  // (A new file is made the same way: whole when its name appears.)
  void save_by_rename(const std::string& name, const std::string& text) {
    const std::filesystem::path file = dir / name, temporary = file.parent_path() / ("." + file.filename().string() + ".swp");
    std::filesystem::create_directories(file.parent_path());
    std::ofstream(temporary, std::ios::binary) << text;
    std::filesystem::rename(temporary, file);
  }
  nlohmann::json manifest() { return nlohmann::json::parse(testing::read_file(dir / "out/p.manifest.json")); }
  // Every file of the output directory, by name, with its bytes.
  std::map<std::string, std::string> output_files() {
    std::map<std::string, std::string> files;
    for (const auto& file : testing::files_below(dir / "out")) files[file.filename().string()] = testing::read_file(file);
    return files;
  }
};

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// The loop itself: a save by rename (as editors save) and a write in place each start a round that names the file,
// and the pack in the output directory is the new one: other inputs, other SPIR-V.
TEST_F(Watch, EachSavedInputStartsARoundThatPublishesItsPack) {
  start();
  std::string line = status();
  EXPECT_TRUE(contains(line, "kiln watch: round 1: start; full: 3 variants (6 stage sources compiled, 0 from the cache), ")) << line;
  EXPECT_TRUE(contains(line, "; watching 3 files in ")) << line;  // the pack definition, S.hlsl, lib/Colour.hlsl
  const nlohmann::json first = manifest();
  const std::string first_archive = testing::read_archive(dir / "out/p.manifest.json");

  save_by_rename("S.hlsl", shader("5.0"));
  line = status();
  EXPECT_TRUE(contains(line, "kiln watch: round 2: S.hlsl changed; full: 3 variants (2 stage sources compiled, 4 from the cache), ")) << line;
  const nlohmann::json second = manifest();
  EXPECT_NE(second["inputs_hash"], first["inputs_hash"]);
  EXPECT_NE(testing::read_archive(dir / "out/p.manifest.json"), first_archive);

  dir.write("lib/Colour.hlsl", colour("0.5"));  // in place: IN_CLOSE_WRITE
  line = status();
  EXPECT_TRUE(contains(line, "kiln watch: round 3: lib/Colour.hlsl changed; full: 3 variants (6 stage sources compiled, 0 from the cache)")) << line;
  EXPECT_NE(manifest()["inputs_hash"], second["inputs_hash"]);
  EXPECT_EQ(kiln->end(SIGTERM), 0) << kiln->err();
}

// A broken edit shows its diagnostic and changes nothing in the output directory; an edit that makes the plan
// itself fail (an include that is not there) stops it before it knows what it reads: creating the file starts the
// next round all the same.
TEST_F(Watch, ABrokenEditPrintsItsDiagnosticAndLeavesTheLastGoodPackUntouched) {
  start();
  status();
  const std::map<std::string, std::string> good = output_files();
  ASSERT_EQ(good.size(), 3u);  // manifest, archive, stamp

  save_by_rename("S.hlsl", shader("undefinedThing"));
  std::string line = status();
  EXPECT_TRUE(contains(line, "round 2: S.hlsl changed; full: failed (1 error; the pack is left as it was)")) << line;
  EXPECT_TRUE(contains(kiln->err(), "S.hlsl:6:21: error[K1401]: 'undefinedThing' : unknown variable")) << kiln->err();
  EXPECT_EQ(output_files(), good);

  save_by_rename("S.hlsl", "#include \"Missing.hlsl\"\n" + shader());
  line = status();
  EXPECT_TRUE(contains(line, "round 3: S.hlsl changed; full: failed (1 error")) << line;
  EXPECT_TRUE(contains(kiln->err(), "cannot find include file 'Missing.hlsl'")) << kiln->err();
  EXPECT_EQ(output_files(), good);

  save_by_rename("lib/Missing.hlsl", "// found now\n");
  line = status();
  EXPECT_TRUE(contains(line, "round 4: lib/Missing.hlsl changed; full: 3 variants (")) << line;
  EXPECT_NE(output_files(), good);
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// A header created where the include search looks first (beside the including file, before the include root) takes
// the old one's place: watch sees the new name in that directory and builds with it.
TEST_F(Watch, ANewHeaderThatShadowsAnIncludeStartsARound) {
  start();
  status();
  const nlohmann::json before = manifest();
  save_by_rename("Colour.hlsl", colour("0.75"));
  const std::string line = status();
  EXPECT_TRUE(contains(line, "round 2: Colour.hlsl changed; full: 3 variants (6 stage sources compiled, 0 from the cache)")) << line;
  EXPECT_NE(manifest()["inputs_hash"], before["inputs_hash"]);
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// With --usage, each round publishes the variants the log asks for first, then the full pack: the output directory
// sees the in-use archive, then the manifest naming it, before the full archive. The log is read again each round;
// a broken variant outside it leaves the in-use pack in place.
TEST_F(Watch, WithUsageTheVariantsInUseArePublishedBeforeTheFullPack) {
  dir.write("usage/run.json", usage_log({"A"}));
  start({"--usage", "usage/run.json"});
  std::string line = status();
  EXPECT_TRUE(contains(line, "round 1: start; in use: 1 variant (2 stage sources compiled, 0 from the cache), ")) << line;
  EXPECT_TRUE(contains(line, "; full: 3 variants (4 stage sources compiled, 2 from the cache), ")) << line;
  EXPECT_TRUE(contains(line, "watching 3 files")) << line;  // not the usage log: a running game keeps writing it

  const int events = ::inotify_init1(IN_CLOEXEC);
  ASSERT_GE(::inotify_add_watch(events, (dir / "out").c_str(), IN_MOVED_TO), 0);
  save_by_rename("S.hlsl", shader("7.0"));
  line = status();
  EXPECT_TRUE(contains(line, "round 2: S.hlsl changed; in use: 1 variant (2 stage sources compiled, 0 from the cache), ")) << line;
  EXPECT_TRUE(contains(line, "; full: 3 variants (0 stage sources compiled, 6 from the cache), ")) << line;
  std::vector<std::string> published;  // the archives and manifests renamed into place, in order
  alignas(inotify_event) char buffer[4096];
  pollfd entry{events, POLLIN, 0};
  while (::poll(&entry, 1, 0) > 0) {
    const ssize_t n = ::read(events, buffer, sizeof buffer);
    for (ssize_t at = 0; at < n;) {
      const auto* event = reinterpret_cast<const inotify_event*>(buffer + at);
      const std::string name = event->name;
      if (name.ends_with(".kpack")) published.push_back("archive " + name);
      if (name == "p.manifest.json") published.push_back("manifest");
      at += static_cast<ssize_t>(sizeof(inotify_event) + event->len);
    }
  }
  ::close(events);
  const std::string full_archive = manifest()["archive"]["file"];
  ASSERT_EQ(published.size(), 4u) << ::testing::PrintToString(published);
  EXPECT_TRUE(published[0].starts_with("archive ") && published[0] != "archive " + full_archive) << published[0];
  EXPECT_EQ(published[1], "manifest");
  EXPECT_EQ(published[2], "archive " + full_archive);
  EXPECT_EQ(published[3], "manifest");

  // B is not in use: breaking it fails the full pack only, and the output directory holds the in-use one.
  save_by_rename("S.hlsl", shader("7.0", "return undefinedB;"));
  line = status();
  EXPECT_TRUE(contains(line, "round 3: S.hlsl changed; in use: 1 variant (")) << line;
  EXPECT_TRUE(contains(line, "; full: failed (1 error; the in-use pack stays)")) << line;
  EXPECT_TRUE(contains(kiln->err(), "'undefinedB' : unknown variable")) << kiln->err();
  EXPECT_EQ(manifest()["passes"][0]["variants"].size(), 1u);

  // The game asked for more since: the next round's in-use pack has it.
  dir.write("usage/run.json", usage_log({"A", ""}));
  save_by_rename("S.hlsl", shader("7.0"));
  line = status();
  EXPECT_TRUE(contains(line, "round 4: S.hlsl changed; in use: 2 variants (")) << line;
  EXPECT_TRUE(contains(line, "; full: 3 variants (")) << line;
  EXPECT_EQ(manifest()["passes"][0]["variants"].size(), 3u);
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// An edit while the in-use pack is being built ends the round there (no full pack of stale inputs) and the next round
// builds it. The edit lands inside the build deterministically: a compiler worker (KILN_WORKER, a script that runs the
// real one) that finds a hold file says so through one FIFO and waits for the test to open a second one.
TEST_F(Watch, AnEditDuringTheInUseBuildRestartsTheRound) {
  const std::filesystem::path worker = dir / "gate/worker";  // not where the inputs are: no round of its own
  const std::string real = (std::filesystem::path(KILN_CLI_PATH).parent_path() / "kiln-worker").string();
  dir.write("gate/worker", "#!/bin/sh\nif [ -e \"$0.hold\" ]; then echo started > \"$0.started\"; read line < \"$0.gate\"; fi\n"
                            "exec '" + real + "' \"$@\"\n");
  std::filesystem::permissions(worker, std::filesystem::perms::owner_all);
  ASSERT_EQ(::mkfifo((worker.string() + ".started").c_str(), 0600), 0);
  ASSERT_EQ(::mkfifo((worker.string() + ".gate").c_str(), 0600), 0);
  dir.write("usage/run.json", usage_log({"A"}));
  ::setenv("KILN_WORKER", worker.c_str(), 1);
  start({"--usage", "usage/run.json"});
  ::unsetenv("KILN_WORKER");
  std::string line = status();
  EXPECT_TRUE(contains(line, "round 1: start; in use: 1 variant (")) << line;

  dir.write("gate/worker.hold", "");
  save_by_rename("S.hlsl", shader("6.0"));
  EXPECT_EQ(testing::read_file(worker.string() + ".started"), "started\n");  // the in-use build waits for its worker
  std::filesystem::remove(dir / "gate/worker.hold");
  save_by_rename("S.hlsl", shader("9.0"));
  std::ofstream(worker.string() + ".gate") << "go\n";
  line = status();
  EXPECT_TRUE(contains(line, "round 2: S.hlsl changed; in use: 1 variant (2 stage sources compiled, ")) << line;
  EXPECT_TRUE(contains(line, "; full: restarted (inputs changed during the round)")) << line;
  line = status();
  EXPECT_TRUE(contains(line, "round 3: S.hlsl changed; in use: 1 variant (2 stage sources compiled, ")) << line;
  EXPECT_TRUE(contains(line, "; full: 3 variants (")) << line;
  EXPECT_EQ(manifest()["passes"][0]["variants"].size(), 3u);
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// An edit while the full pack is being built stops that build (the jobs not handed out are not run, nothing is
// written) and the next round builds the new inputs. The full build's worker waits at the gate, as above.
TEST_F(Watch, AnEditDuringTheFullBuildStopsItAndTheNextRoundBuildsTheNewInputs) {
  const std::filesystem::path worker = dir / "gate/worker";
  const std::string real = (std::filesystem::path(KILN_CLI_PATH).parent_path() / "kiln-worker").string();
  dir.write("gate/worker", "#!/bin/sh\nif [ -e \"$0.hold\" ]; then echo started > \"$0.started\"; read line < \"$0.gate\"; fi\n"
                            "exec '" + real + "' \"$@\"\n");
  std::filesystem::permissions(worker, std::filesystem::perms::owner_all);
  ASSERT_EQ(::mkfifo((worker.string() + ".started").c_str(), 0600), 0);
  ASSERT_EQ(::mkfifo((worker.string() + ".gate").c_str(), 0600), 0);
  ::setenv("KILN_WORKER", worker.c_str(), 1);
  start();
  ::unsetenv("KILN_WORKER");
  std::string line = status();
  EXPECT_TRUE(contains(line, "round 1: start; full: 3 variants (")) << line;
  const std::map<std::string, std::string> round_1 = output_files();

  dir.write("gate/worker.hold", "");
  save_by_rename("S.hlsl", shader("6.0"));
  EXPECT_EQ(testing::read_file(worker.string() + ".started"), "started\n");  // the full build waits for its worker
  std::filesystem::remove(dir / "gate/worker.hold");
  save_by_rename("lib/Colour.hlsl", colour("0.5"));
  std::ofstream(worker.string() + ".gate") << "go\n";
  line = status();
  EXPECT_TRUE(contains(line, "round 2: S.hlsl changed; full: restarted (inputs changed during the round)")) << line;
  EXPECT_EQ(output_files(), round_1);  // the stopped build wrote nothing
  line = status();
  EXPECT_TRUE(contains(line, "round 3: lib/Colour.hlsl changed; full: 3 variants (")) << line;
  EXPECT_NE(output_files(), round_1);
  EXPECT_EQ(manifest()["passes"][0]["variants"].size(), 3u);
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

// Ctrl-C and a service manager's stop end watch with 0 and leave the pack whole: no temporary file, no orphan.
TEST_F(Watch, SigintAndSigtermEndItWithZeroAndNoTemporaryFiles) {
  for (int signal : {SIGTERM, SIGINT}) {
    start();
    status();
    save_by_rename("S.hlsl", shader(signal == SIGTERM ? "3.0" : "4.0"));
    status();
    EXPECT_EQ(kiln->end(signal), 0) << kiln->err();
    std::vector<std::string> names;
    for (const auto& [name, bytes] : output_files()) names.push_back(name);
    ASSERT_EQ(names.size(), 3u) << ::testing::PrintToString(names);
    EXPECT_EQ(names[0], manifest()["archive"]["file"]);
    EXPECT_EQ(names[1], "p.manifest.json");
    EXPECT_EQ(names[2], "p.stamp");
  }
}

// Hours of edits do not grow it: over 30 rounds (some broken, some served from the cache) its open descriptors
// stay as many as after the first edit.
TEST_F(Watch, OpenDescriptorsStayFlatOverThirtyEdits) {
  start();
  status();
  save_by_rename("S.hlsl", shader("1.5"));
  status();
  const size_t after_first_edit = kiln->open_descriptors();
  ASSERT_GT(after_first_edit, 3u);
  unsigned round = 2;
  auto expect_round = [&](const std::string& what) {
    const std::string line = status();
    EXPECT_TRUE(contains(line, "round " + std::to_string(++round) + ": " + what)) << line;
  };
  for (int edit = 0; edit < 30; ++edit) {
    if (edit % 5 == 4) {
      save_by_rename("S.hlsl", shader("undefinedThing"));
      expect_round("S.hlsl changed; full: failed");
      save_by_rename("S.hlsl", shader("1.5"));
      expect_round("S.hlsl changed; full: 3 variants (");
    } else {
      dir.write("lib/Colour.hlsl", colour(std::to_string(edit % 3) + ".0"));
      expect_round("lib/Colour.hlsl changed; full: 3 variants (");
    }
  }
  EXPECT_LE(kiln->open_descriptors(), after_first_edit);
  EXPECT_EQ(kiln->end(SIGTERM), 0);
}

}  // namespace
}  // namespace kiln
