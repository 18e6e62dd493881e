// SPDX-License-Identifier: Apache-2.0
// Whole builds through the library: determinism, incremental rebuilds, the bundled library.
#include <gtest/gtest.h>

#include <sstream>

#include <algorithm>
#include <csignal>
#include <map>
#include <set>

#include "cache/cache.hpp"
#include "common/files.hpp"
#include "common/hash.hpp"
#include "kiln/build.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "kiln/pack_tools.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

// `worker`: the shipped worker, or the tests' fault-injecting one (tests/support/fault_worker.cpp).
BuildReport build(const std::filesystem::path& pack, const std::filesystem::path& out,
                  std::optional<std::filesystem::path> cache, unsigned jobs, DiagnosticSink& sink,
                  const char* worker = KILN_WORKER_PATH) {
  BuildOptions options;
  options.pack_file = pack;
  options.output_dir = out;
  options.cache_dir = cache;
  options.jobs = jobs;
  options.worker_executable = worker;
  return build_pack(options, sink);
}

using testing::errors_of;

struct SmallLibrary : ::testing::Test {
  testing::TempDir dir;
  void SetUp() override {
    dir.write("lib/Shadows.hlsl", "#pragma once\nfloat ShadowTerm(float x) { return saturate(x * 0.5); }\n");
    dir.write("lib/Fog.hlsl", "#pragma once\nfloat FogTerm(float x) { return exp2(-x); }\n");
    dir.write("S.hlsl",
              "#pragma multi_compile _ SHADOWS\n#pragma multi_compile_fragment _ FOG\n"
              "#include \"Shadows.hlsl\"\n#ifdef FOG\n#include \"Fog.hlsl\"\n#endif\n"
              "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
              "float4 F(float4 p : SV_Position) : SV_Target {\n  float c = 1.0;\n"
              "#ifdef SHADOWS\n  c *= ShadowTerm(p.x);\n#endif\n#ifdef FOG\n  c *= FogTerm(p.y);\n#endif\n"
              "  return float4(c, c, c, 1.0);\n}\n");
    dir.write("p.pack.json", R"({"name": "p", "include_dirs": ["lib"],
      "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  }
};

TEST_F(SmallLibrary, SameBytesWithOneWorkerAndWithTwo) {
  DiagnosticSink sink;
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "j1", std::nullopt, 1, sink).ok) << errors_of(sink);
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "j2", std::nullopt, 2, sink).ok) << errors_of(sink);
  EXPECT_EQ(testing::read_archive(dir / "j1/p.manifest.json"), testing::read_archive(dir / "j2/p.manifest.json"));
  EXPECT_EQ(testing::read_file(dir / "j1/p.manifest.json"), testing::read_file(dir / "j2/p.manifest.json"));
}

// The same sources checked out at two places (two CI runners, a developer's home) make the same pack, manifest
// included: its inputs hash, also the remote's pack-level key, names files by their path from the pack.
TEST_F(SmallLibrary, TheSameSourcesCheckedOutElsewhereGiveTheSameBytes) {
  for (const char* file : {"lib/Shadows.hlsl", "lib/Fog.hlsl", "S.hlsl", "p.pack.json"})
    dir.write(std::string("elsewhere/deeper/") + file, testing::read_file(dir / file));
  DiagnosticSink sink;
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "here", std::nullopt, 2, sink).ok) << errors_of(sink);
  ASSERT_TRUE(build(dir / "elsewhere/deeper/p.pack.json", dir / "there", std::nullopt, 2, sink).ok) << errors_of(sink);
  EXPECT_EQ(testing::read_file(dir / "here/p.manifest.json"), testing::read_file(dir / "there/p.manifest.json"));
  EXPECT_EQ(testing::read_archive(dir / "here/p.manifest.json"), testing::read_archive(dir / "there/p.manifest.json"));
}

TEST_F(SmallLibrary, AFrontEndKilnDoesNotHaveIsAnErrorBeforeAnythingIsWritten) {
  BuildOptions options;
  options.pack_file = dir / "p.pack.json";
  options.output_dir = dir / "out";
  options.cache_dir = dir / "cache";
  options.worker_executable = KILN_WORKER_PATH;
  options.frontend = "dxc";
  DiagnosticSink sink;
  EXPECT_FALSE(build_pack(options, sink).ok);
  EXPECT_EQ(errors_of(sink), (dir / "p.pack.json").string() + ": error[K1013]: no front end named 'dxc' (kiln has: glslang)\n");
  EXPECT_TRUE(testing::files_below(dir / "out").empty());
  EXPECT_TRUE(testing::files_below(dir / "cache").empty());
}

// kiln's includer implements #pragma once (glslang would only warn "not implemented" and include the file
// again): a file included twice is read once, with no warning, and the directive is not in the output.
TEST_F(SmallLibrary, PragmaOnceIsHonouredWithoutAWarning) {
  dir.write("lib/Both.hlsl", "  #  pragma\tonce  /* twice is harmless */\n// evaluated once per pixel\n#include \"Shadows.hlsl\"\n");
  dir.write("S.hlsl", "#include \"Shadows.hlsl\"\n#include \"Both.hlsl\"\n"
                      "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F(float4 p : SV_Position) : SV_Target {\n  return ShadowTerm(p.x).xxxx;\n}\n");
  BuildOptions options;
  options.pack_file = dir / "p.pack.json";
  options.output_dir = dir / "out";
  options.worker_executable = KILN_WORKER_PATH;
  options.emit = {"preprocessed"};
  DiagnosticSink sink;
  ASSERT_TRUE(build_pack(options, sink).ok) << errors_of(sink);
  EXPECT_TRUE(sink.diagnostics().empty()) << errors_of(sink);
  auto emitted = testing::files_below(dir / "out/emit");
  ASSERT_EQ(emitted.size(), 2u);
  for (const auto& file : emitted) {
    const std::string text = testing::read_file(file);
    EXPECT_EQ(text.find("pragma"), std::string::npos) << file;
    size_t definitions = 0;
    for (size_t at = text.find("ShadowTerm(float x)"); at != std::string::npos; at = text.find("ShadowTerm(float x)", at + 1))
      ++definitions;
    EXPECT_EQ(definitions, 1u) << file;
  }
}

TEST_F(SmallLibrary, NoChangeRebuildDoesNoWork) {
  DiagnosticSink sink;
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink).ok) << errors_of(sink);
  BuildReport again = build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink);
  EXPECT_TRUE(again.up_to_date);
  EXPECT_EQ(again.compiled, 0u);
  EXPECT_EQ(again.workers_started, 0u);
}

TEST_F(SmallLibrary, IncludeEditRecompilesExactlyTheVariantsThatReadIt) {
  DiagnosticSink sink;
  BuildReport first = build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink);
  ASSERT_TRUE(first.ok) << errors_of(sink);
  // 2 vertex sources (SHADOWS on/off; FOG is fragment-only) + 4 fragment sources.
  EXPECT_EQ(first.funnel.unique_compiles, 6u);
  EXPECT_EQ(first.compiled, 6u);
  // V never calls ShadowTerm: both vertex sources give one front-end module, so one vertex back end.
  EXPECT_EQ(first.back_ends, 5u);
  EXPECT_EQ(first.funnel.unique_modules, 5u);
  dir.write("lib/Fog.hlsl", "#pragma once\nfloat FogTerm(float x) { return exp2(-2.0 * x); }\n");
  BuildReport second = build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink);
  ASSERT_TRUE(second.ok) << errors_of(sink);
  EXPECT_FALSE(second.up_to_date);
  // Only the fragment variants with FOG include Fog.hlsl: 2 recompiles, 4 cache hits.
  EXPECT_EQ(second.compiled, 2u);
  EXPECT_EQ(second.cache_hits, 4u);
}

TEST_F(SmallLibrary, SourcesWhoseFilesAreUnchangedAreNotPreprocessedAgain) {
  DiagnosticSink sink;
  BuildReport first = build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink);
  ASSERT_TRUE(first.ok) << errors_of(sink);
  EXPECT_EQ(first.preprocess_memo_hits, 0u);
  dir.write("lib/Fog.hlsl", "#pragma once\nfloat FogTerm(float x) { return exp2(-2.0 * x); }\n");
  BuildReport second = build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink);
  ASSERT_TRUE(second.ok) << errors_of(sink);
  EXPECT_EQ(second.preprocess_memo_hits, 4u);  // all but the two FOG fragment sources, which read Fog.hlsl
  EXPECT_EQ(second.compiled, 2u);
  BuildReport third = build(dir / "p.pack.json", dir / "fresh", dir / "cache", 2, sink);
  ASSERT_TRUE(third.ok) << errors_of(sink);
  EXPECT_EQ(third.preprocess_memo_hits, 6u);
  EXPECT_EQ(third.compiled, 0u);
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "reference", std::nullopt, 2, sink).ok) << errors_of(sink);
  EXPECT_EQ(testing::read_archive(dir / "fresh/p.manifest.json"), testing::read_archive(dir / "reference/p.manifest.json"));
  // Back to the first Fog.hlsl: the memos of both versions are kept, so nothing is preprocessed.
  dir.write("lib/Fog.hlsl", "#pragma once\nfloat FogTerm(float x) { return exp2(-x); }\n");
  BuildReport fourth = build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink);
  ASSERT_TRUE(fourth.ok) << errors_of(sink);
  EXPECT_EQ(fourth.preprocess_memo_hits, 6u);
  EXPECT_EQ(fourth.cache_hits, 6u);
}

TEST_F(SmallLibrary, ANewFileAnIncludeWouldNowFindIsNotHiddenByAMemo) {
  dir.write("over/Unrelated.hlsl", "float Unrelated() { return 0.0; }\n");
  dir.write("p.pack.json", R"({"name": "p", "include_dirs": ["over", "lib"],
      "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  DiagnosticSink sink;
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink).ok) << errors_of(sink);
  // Fog.hlsl in the first root now shadows lib/Fog.hlsl; no file any source read has changed.
  dir.write("over/Fog.hlsl", "#pragma once\nfloat FogTerm(float x) { return 0.25 * x; }\n");
  BuildReport second = build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink);
  ASSERT_TRUE(second.ok) << errors_of(sink);
  EXPECT_EQ(second.preprocess_memo_hits, 0u);
  EXPECT_EQ(second.compiled, 2u);  // the FOG fragment sources, now reading over/Fog.hlsl
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "reference", std::nullopt, 2, sink).ok) << errors_of(sink);
  EXPECT_EQ(testing::read_archive(dir / "out/p.manifest.json"), testing::read_archive(dir / "reference/p.manifest.json"));
}

// A memo gives a source's key without its text; when the cache then lacks the result (here: the largest
// record, a back end's result, corrupted), the source is preprocessed for the worker after all.
TEST_F(SmallLibrary, AMissKnownOnlyThroughAMemoIsPreprocessedForTheWorkers) {
  DiagnosticSink sink;
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink).ok) << errors_of(sink);
  const std::string archive = testing::read_archive(dir / "out/p.manifest.json");
  auto segments = testing::files_below(dir / "cache");
  ASSERT_EQ(segments.size(), 1u);
  std::string bytes = testing::read_file(segments[0]);
  auto get = [&](size_t at, int width) {
    uint64_t v = 0;
    for (int i = 0; i < width; ++i) v |= static_cast<uint64_t>(static_cast<unsigned char>(bytes[at + i])) << (8 * i);
    return v;
  };
  const uint64_t count = get(12, 4), index = get(16, 8);
  uint64_t largest_offset = 0, largest_size = 0;
  for (uint64_t i = 0; i < count; ++i)
    if (get(index + i * 32 + 24, 8) > largest_size) {
      largest_offset = get(index + i * 32 + 16, 8);
      largest_size = get(index + i * 32 + 24, 8);
    }
  bytes[largest_offset + largest_size / 2] ^= 1;
  dir.write(segments[0].lexically_relative(dir.path()).string(), bytes);
  BuildReport second = build(dir / "p.pack.json", dir / "fresh", dir / "cache", 2, sink);
  ASSERT_TRUE(second.ok) << errors_of(sink);
  EXPECT_EQ(second.preprocess_memo_hits, 6u);
  EXPECT_GE(second.compiled, 1u);
  EXPECT_GE(second.cache_rejected, 1u);
  EXPECT_EQ(testing::read_archive(dir / "fresh/p.manifest.json"), archive);
  // Said once, as a note, not an error.
  const auto notes = sink.diagnostics();
  ASSERT_EQ(notes.size(), 1u) << errors_of(sink);
  EXPECT_EQ(notes[0].id, DiagId::CacheEntryRejected);
  EXPECT_EQ(notes[0].severity, Severity::Note);
  EXPECT_EQ(notes[0].message, std::to_string(second.cache_rejected) +
                                  (second.cache_rejected == 1 ? " cache entry was" : " cache entries were") +
                                  " corrupt, truncated or foreign: compiled again and rewritten");
}

TEST_F(SmallLibrary, EditThatChangesNoReachableCodeRunsOnlyFrontEnds) {
  DiagnosticSink sink;
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink).ok) << errors_of(sink);
  const std::string first_archive = testing::read_archive(dir / "out/p.manifest.json");
  // A comment and a helper nobody calls: every stage source's text changes, no entry point's code does.
  dir.write("lib/Shadows.hlsl", "#pragma once\n// soft shadows: later\nfloat Unused(float x) { return x * x; }\n"
                                "float ShadowTerm(float x) { return saturate(x * 0.5); }\n");
  BuildReport second = build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink);
  ASSERT_TRUE(second.ok) << errors_of(sink);
  EXPECT_EQ(second.cache_hits, 0u);
  EXPECT_EQ(second.compiled, 6u);
  EXPECT_EQ(second.back_ends, 0u);
  EXPECT_EQ(second.back_end_hits, 5u);
  EXPECT_EQ(testing::read_archive(dir / "out/p.manifest.json"), first_archive);
  // The sources' new keys now name those modules: a fresh output directory is served whole from the cache.
  BuildReport third = build(dir / "p.pack.json", dir / "fresh", dir / "cache", 2, sink);
  ASSERT_TRUE(third.ok) << errors_of(sink);
  EXPECT_EQ(third.cache_hits, 6u);
  EXPECT_EQ(third.compiled, 0u);
  EXPECT_EQ(third.funnel.unique_modules, 5u);  // known through the aliases, without compiling
  EXPECT_EQ(testing::read_archive(dir / "fresh/p.manifest.json"), first_archive);
}

// Two fragment sources that differ only in a function F never calls (so they share one module), F calling
// `fault` (a function name the fault-injecting worker acts on), built with that worker.
BuildReport build_with_fault_injection(const testing::TempDir& dir, const std::string& fault, DiagnosticSink& sink) {
  dir.write("S.hlsl", "#pragma multi_compile_fragment _ UNUSED_BRANCH\nfloat " + fault + "(float x) { return x * 0.5; }\n"
                      "#ifdef UNUSED_BRANCH\nfloat NeverCalled() { return 2.0; }\n#endif\n"
                      "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F(float4 c : COLOR0) : SV_Target { return " + fault + "(c.x).xxxx; }\n");
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  return build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink, KILN_FAULT_WORKER_PATH);
}

// Thirty lines of macros expand to 2^31 tokens. Preprocessing runs in the compiler workers, so the bomb costs
// one worker its memory limit and is reported as the source's error (exit 1), where it used to grow kiln itself
// until it aborted with an uncaught std::bad_alloc after minutes. The other passes are still built.
TEST(Limits, AMacroBombIsAPreprocessingErrorAndTheRestIsStillBuilt) {
  testing::TempDir dir;
  std::string bomb = "#define A0 x x\n";
  for (int i = 1; i <= 30; ++i)
    bomb += "#define A" + std::to_string(i) + " A" + std::to_string(i - 1) + " A" + std::to_string(i - 1) + "\n";
  dir.write("Bomb.hlsl", bomb + "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                                "float4 F() : SV_Target { A30; return 1.0; }\n");
  dir.write("Good.hlsl", "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                         "float4 F() : SV_Target { return 1.0; }\n");
  dir.write("p.pack.json", R"({"name": "p", "passes": [
    {"name": "Bomb", "source": "Bomb.hlsl", "stages": {"vertex": "V", "fragment": "F"}},
    {"name": "Good", "source": "Good.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  BuildOptions options;
  options.pack_file = dir / "p.pack.json";
  options.output_dir = dir / "out";
  options.worker_executable = KILN_WORKER_PATH;
  options.worker_memory_limit_mb = 128;  // enough for two tiny shaders, low enough that the bomb meets it in seconds
  DiagnosticSink sink;
  BuildReport report = build_pack(options, sink);
  EXPECT_FALSE(report.ok);
  EXPECT_FALSE(report.internal_errors) << errors_of(sink);
  EXPECT_EQ(exit_code(sink, report.internal_errors), 1);
  std::vector<Diagnostic> errors = sink.diagnostics();
  ASSERT_EQ(errors.size(), 1u) << errors_of(sink);
  EXPECT_EQ(errors[0].id, DiagId::PreprocessorError);
  EXPECT_EQ(errors[0].location.path, display_path(dir / "Bomb.hlsl"));
  // Out of memory or out of time, whichever limit the bomb meets first: both say what it likely is.
  EXPECT_NE(errors[0].message.find("(a macro that expands exponentially?)"), std::string::npos) << errors[0].message;
  // Both stages of the good pass preprocessed and compiled; only the bomb's fragment stage failed.
  EXPECT_EQ(report.funnel.unique_preprocessed, 4u);
}

// A worker that dies while preprocessing is an internal compiler error with a reproducer, as one that dies while
// compiling is (9 of 16 worker kills used to give exit 2 and no reproducer): the entry file with the job's defines.
TEST(TwoHalves, AWorkerThatDiesWhilePreprocessingLeavesAReproducer) {
  testing::TempDir dir;
  dir.write("S.hlsl", "// kiln-fault: crash-preprocess\n#pragma multi_compile_fragment _ FAST\n"
                      "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                      "float4 F() : SV_Target { return 1.0; }\n");
  dir.write("p.pack.json", R"({"name": "p", "defines": {"LEVEL": 2},
    "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  DiagnosticSink sink;
  BuildReport report = build(dir / "p.pack.json", dir / "out", dir / "cache", 2, sink, KILN_FAULT_WORKER_PATH);
  EXPECT_TRUE(report.internal_errors);
  EXPECT_EQ(exit_code(sink, report.internal_errors), 2);
  const auto repro = dir / "out/kiln-ice/P.fragment.FAST.preprocess.hlsl";
  ASSERT_TRUE(std::filesystem::exists(repro)) << errors_of(sink);
  const std::string text = testing::read_file(repro);
  EXPECT_NE(text.find("// reproduce (from "), std::string::npos) << text;
  EXPECT_NE(text.find("glslangValidator -E -DLEVEL=2 -DFAST S.hlsl\n"), std::string::npos) << text;
  EXPECT_NE(text.find("#define LEVEL 2\n#define FAST 1\n#line 1\n// kiln-fault: crash-preprocess\n"), std::string::npos) << text;
  bool noted = false;
  for (const Diagnostic& d : sink.diagnostics()) {
    EXPECT_EQ(d.id, DiagId::InternalCompilerError) << format_diagnostic(d);
    for (const std::string& note : d.notes) noted = noted || note == "reproducer written to " + repro.string();
  }
  EXPECT_TRUE(noted) << errors_of(sink);
}

// An exception inside a worker (a library throwing where it should not) is an internal compiler error with
// exit code 2 and a reproducer, not a user error: it used to land on K1404 "optimizer failed" with exit 1.
TEST(TwoHalves, AnExceptionInAWorkerIsAnInternalCompilerError) {
  testing::TempDir dir;
  DiagnosticSink sink;
  BuildReport report = build_with_fault_injection(dir, "kiln_fault_throw", sink);
  EXPECT_FALSE(report.ok);
  EXPECT_TRUE(report.internal_errors);
  EXPECT_EQ(exit_code(sink, report.internal_errors), 2);
  ASSERT_FALSE(sink.diagnostics().empty());
  for (const Diagnostic& d : sink.diagnostics()) {
    EXPECT_EQ(d.id, DiagId::InternalCompilerError) << format_diagnostic(d);
    EXPECT_NE(d.message.find("the compiler worker threw an exception (injected worker exception) while compiling pass 'P'"),
              std::string::npos) << d.message;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "out/p.manifest.json"));
}

// A back end that rejects its module (spirv-val, given a module whose Location decorations a front-end bug
// lost; the optimizer, given a truncated one) is an error of every source sharing the module, named by stage
// and keywords; nothing is cached.
TEST(TwoHalves, ModuleTheBackEndRejectsIsAnErrorForEverySourceSharingItAndNothingIsCached) {
  struct Case {
    const char* fault;
    DiagId id;
    const char* message;
  };
  for (const Case& c : {Case{"KilnFaultInvalidModule", DiagId::SpirvInvalid,
                             "validate: instruction 21: [VUID-StandaloneSpirv-Location-04916] Variable must be decorated "
                             "with a location\n  %c = OpVariable %_ptr_Input_v4float Input"},
                        Case{"KilnFaultTruncatedModule", DiagId::OptimizerFailed, "legalize: "}}) {
    testing::TempDir dir;
    DiagnosticSink sink;
    BuildReport report = build_with_fault_injection(dir, c.fault, sink);
    EXPECT_FALSE(report.ok);
    EXPECT_FALSE(report.internal_errors);
    EXPECT_EQ(report.back_ends, 2u);  // 1 vertex + 1 fragment module
    const auto diagnostics = sink.diagnostics();
    ASSERT_EQ(diagnostics.size(), 1u) << errors_of(sink);
    EXPECT_EQ(diagnostics[0].id, c.id) << c.fault;
    EXPECT_EQ(diagnostics[0].location.path, (dir / "S.hlsl").string());
    EXPECT_TRUE(diagnostics[0].message.starts_with(c.message)) << diagnostics[0].message;
    EXPECT_NE(diagnostics[0].message.back(), '\n');
    EXPECT_EQ(diagnostics[0].notes, (std::vector<std::string>{"in pass 'P' fragment stage, keywords [<none>]",
                                                               "and in 1 more variant(s)"}));
    EXPECT_FALSE(std::filesystem::exists(dir / "out/p.manifest.json"));
    EXPECT_EQ(Cache(dir / "cache").indexed_keys(), 0u);
  }
}

// One back end serves both fragment sources: when it crashes, both are internal compiler errors (each with its
// keywords), and only the vertex stage is cached.
TEST(TwoHalves, BackEndCrashIsAnInternalErrorForEverySourceSharingItsModule) {
  testing::TempDir dir;
  DiagnosticSink sink;
  BuildReport report = build_with_fault_injection(dir, "KilnFaultCrashBackEnd", sink);
  EXPECT_FALSE(report.ok);
  EXPECT_TRUE(report.internal_errors);
  EXPECT_EQ(report.compiled, 3u);   // 1 vertex + 2 fragment sources
  EXPECT_EQ(report.back_ends, 2u);  // 1 vertex + 1 fragment module
  std::vector<std::string> crashed;
  for (const Diagnostic& d : sink.diagnostics())
    if (d.id == DiagId::InternalCompilerError) crashed.push_back(d.message);
  ASSERT_EQ(crashed.size(), 2u) << errors_of(sink);
  std::sort(crashed.begin(), crashed.end());
  EXPECT_NE(crashed[0].find("signal 11"), std::string::npos) << crashed[0];
  EXPECT_NE(crashed[0].find("fragment stage, keywords [<none>]"), std::string::npos) << crashed[0];
  EXPECT_NE(crashed[1].find("fragment stage, keywords [UNUSED_BRANCH]"), std::string::npos) << crashed[1];
  // Each reproducer comes with the module the back end was given, and that module is valid front-end output.
  size_t modules_written = 0;
  for (const auto& f : testing::files_below(dir / "out/kiln-ice"))
    if (f.extension() == ".spv") {
      ++modules_written;
      std::string bytes = testing::read_file(f);
      ASSERT_GE(bytes.size(), 4u);
      EXPECT_EQ(static_cast<unsigned char>(bytes[0]), 0x03);  // SPIR-V magic 0x07230203, little-endian
      EXPECT_NE(bytes.find("KilnFaultCrashBackEnd"), std::string::npos);
    }
  EXPECT_EQ(modules_written, 2u);
  EXPECT_FALSE(std::filesystem::exists(dir / "out/p.manifest.json"));
  // The vertex source's alias and its module, and the three sources' preprocessing memos.
  EXPECT_EQ(Cache(dir / "cache").indexed_keys(), 5u);
}

// Legalization runs kiln's core recipe first and SPIRV-Tools' full one only when the core result does not
// validate. EvaluateAttributeAtSample on an interpolant passed through a function is such a case: after
// inlining, the interpolant is a local copy, which only the full recipe's interpolate-fixup turns back into a
// pointer to the input variable.
TEST(Legalization, FullRecipeOnlyWhenTheCoreRecipesResultIsNotValid) {
  testing::TempDir dir;
  dir.write("S.hlsl",
            "#pragma multi_compile_fragment _ AT_SAMPLE\n"
            "struct Interpolants { float4 position : SV_Position; float2 uv : TEXCOORD0; };\n"
            "Texture2D _MainTex : register(t0);\nSamplerState _Sampler : register(s1);\n"
            "float2 SampleUv(Interpolants i) {\n#ifdef AT_SAMPLE\n  return EvaluateAttributeAtSample(i.uv, 0);\n"
            "#else\n  return i.uv;\n#endif\n}\n"
            "Interpolants V(float4 p : POSITION) { Interpolants o; o.position = p; o.uv = p.xy; return o; }\n"
            "float4 F(Interpolants i) : SV_Target { return _MainTex.Sample(_Sampler, SampleUv(i)); }\n");
  // Not MSL: SPIRV-Cross needs MSL 2.3 for pull-model interpolation, kiln targets 2.1.
  dir.write("p.pack.json", R"({"name": "p", "targets": ["spirv", "glsl"], "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  DiagnosticSink sink;
  BuildReport report = build(dir / "p.pack.json", dir / "out", std::nullopt, 2, sink);
  ASSERT_TRUE(report.ok) << errors_of(sink);
  EXPECT_EQ(report.back_ends, 3u);           // 1 vertex + 2 fragment modules
  EXPECT_EQ(report.full_legalizations, 1u);  // the AT_SAMPLE fragment
  PackReader reader = PackReader::open(dir / "out");
  const StageView* fragment = reader.select("P", {"AT_SAMPLE"}).stage("fragment");
  ASSERT_NE(fragment, nullptr);
  EXPECT_NE(std::string(fragment->glsl).find("interpolateAtSample"), std::string::npos) << fragment->glsl;

  // Without optimization, every module gets the full recipe: the output is what `--legalize-hlsl` gives.
  BuildOptions options;
  options.pack_file = dir / "p.pack.json";
  options.output_dir = dir / "unoptimized";
  options.jobs = 1;
  options.optimize = false;
  options.worker_executable = KILN_WORKER_PATH;
  DiagnosticSink unoptimized_sink;
  BuildReport unoptimized = build_pack(options, unoptimized_sink);
  ASSERT_TRUE(unoptimized.ok) << errors_of(unoptimized_sink);
  EXPECT_EQ(unoptimized.full_legalizations, unoptimized.back_ends);
}

TEST_F(SmallLibrary, DepfileListsEveryIncludedFile) {
  DiagnosticSink sink;
  BuildOptions options;
  options.pack_file = dir / "p.pack.json";
  options.output_dir = dir / "out";
  options.depfile = dir / "p.d";
  options.worker_executable = KILN_WORKER_PATH;
  ASSERT_TRUE(build_pack(options, sink).ok) << errors_of(sink);
  std::string depfile = testing::read_file(dir / "p.d");
  EXPECT_EQ(depfile.find((dir / "out/p.manifest.json").string() + ":"), 0u) << depfile;
  for (const char* file : {"p.pack.json", "S.hlsl", "lib/Shadows.hlsl", "lib/Fog.hlsl"})
    EXPECT_NE(depfile.find(file), std::string::npos) << file;
  // S.hlsl's #include "Shadows.hlsl" is looked for next to S.hlsl first and found in lib/: a Shadows.hlsl new in S.hlsl's
  // directory would take its place, so the directory is a dependency (Ninja and Make see it change). lib/ is not.
  std::set<std::string> lines;
  std::istringstream in(depfile);
  for (std::string line; std::getline(in, line);) {
    line.erase(0, line.find_first_not_of(' '));
    if (line.ends_with(" \\")) line.resize(line.size() - 2);
    lines.insert(line);
  }
  EXPECT_EQ(lines.count(std::filesystem::canonical(dir.path()).string()), 1u) << depfile;
  EXPECT_EQ(lines.count(std::filesystem::canonical(dir / "lib").string()), 0u) << depfile;
}

TEST_F(SmallLibrary, EmitDumpsEveryStage) {
  DiagnosticSink sink;
  BuildOptions options;
  options.pack_file = dir / "p.pack.json";
  options.output_dir = dir / "out";
  options.worker_executable = KILN_WORKER_PATH;
  options.emit = emit_stage_names();
  ASSERT_TRUE(build_pack(options, sink).ok) << errors_of(sink);
  for (const char* file : {"variants.json", "P/fragment/FOG+SHADOWS.hlsl", "P/fragment/FOG+SHADOWS.spvasm",
                           "P/fragment/FOG+SHADOWS.glsl", "P/fragment/FOG+SHADOWS.es.glsl", "P/fragment/FOG+SHADOWS.metal",
                           "P/vertex/_.reflection.json"})
    EXPECT_TRUE(std::filesystem::exists(dir / "out/emit" / file)) << file;
  // The dumps are the pack's outputs (stored compressed, decompressed for --emit).
  PackReader pack = PackReader::open(dir / "out");
  const StageView* fragment = pack.select("P", {"FOG", "SHADOWS"}).stage("fragment");
  ASSERT_NE(fragment, nullptr);
  const std::filesystem::path emitted = dir / "out/emit/P/fragment";
  EXPECT_EQ(testing::read_file(emitted / "FOG+SHADOWS.glsl"), fragment->glsl);
  EXPECT_EQ(testing::read_file(emitted / "FOG+SHADOWS.es.glsl"), fragment->gles);
  EXPECT_EQ(testing::read_file(emitted / "FOG+SHADOWS.metal"), fragment->msl);
  EXPECT_NE(testing::read_file(emitted / "FOG+SHADOWS.spvasm").find("OpEntryPoint Fragment"), std::string::npos);
}

TEST_F(SmallLibrary, LayoutThatDiffersBetweenVariantsIsAnError) {
  dir.write("S.hlsl",
            "#pragma multi_compile_fragment _ SWAP\n"
            "#ifdef SWAP\n[[vk::binding(1, 0)]] Texture2D tex;\n#else\n[[vk::binding(1, 0)]] cbuffer B { float4 x; };\n#endif\n"
            "[[vk::binding(2, 0)]] SamplerState smp;\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "#ifdef SWAP\nfloat4 F() : SV_Target { return tex.Sample(smp, float2(0.5, 0.5)); }\n"
            "#else\nfloat4 F() : SV_Target { return x; }\n#endif\n");
  DiagnosticSink sink;
  EXPECT_FALSE(build(dir / "p.pack.json", dir / "out", std::nullopt, 2, sink).ok);
  EXPECT_TRUE(sink.contains(DiagId::LayoutMismatch)) << errors_of(sink);
}

// HLSL Load and GetDimensions use no sampler; GLSL needs a combined sampler for texelFetch/textureSize, so the
// cross-compiler pairs the texture with a dummy sampler and binds it at the texture's binding.
TEST_F(SmallLibrary, TexelFetchAndSizeQueriesCrossCompileToGl) {
  dir.write("S.hlsl",
            "[[vk::binding(1, 0)]] Texture2D tex;\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target {\n"
            "  uint w, h;\n  tex.GetDimensions(w, h);\n"
            "  return tex.Load(int3(int2(p.xy) % int2(w, h), 0));\n}\n");
  DiagnosticSink sink;
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "out", std::nullopt, 2, sink).ok) << errors_of(sink);
  std::string manifest = testing::read_file(dir / "out/p.manifest.json");
  EXPECT_NE(manifest.find("tex_kiln_no_sampler"), std::string::npos);
}

// The manifest's GL and MSL binding records name each resource by what those APIs see (a cbuffer by its
// block name), and the MSL indices are the ones the MSL source declares.
TEST_F(SmallLibrary, GlAndMslBindingRecordsNameEveryResourceAndMatchTheSource) {
  dir.write("S.hlsl",
            "[[vk::binding(0, 0)]] cbuffer Constants { float4 tint; };\n"
            "[[vk::binding(1, 0)]] Texture2D albedo;\n[[vk::binding(2, 0)]] SamplerState linearClamp;\n"
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target { return tint * albedo.Sample(linearClamp, p.xy); }\n");
  DiagnosticSink sink;
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "out", std::nullopt, 2, sink).ok) << errors_of(sink);
  PackReader pack = PackReader::open(dir / "out");
  const StageView* fragment = pack.variant("P", 0).stage("fragment");
  ASSERT_TRUE(fragment && fragment->reflection);
  const Reflection& reflection = *fragment->reflection;
  ASSERT_TRUE(reflection.glsl && reflection.msl);
  ASSERT_EQ(reflection.glsl->blocks.size(), 1u);
  EXPECT_EQ(reflection.glsl->blocks[0].name, "Constants");
  EXPECT_EQ(reflection.glsl->blocks[0].binding, 0u);
  EXPECT_NE(fragment->glsl.find("uniform Constants"), std::string_view::npos) << fragment->glsl;
  const std::map<MslResourceKind, std::string> expected = {
      {MslResourceKind::Buffer, "buffer"}, {MslResourceKind::Texture, "texture"}, {MslResourceKind::Sampler, "sampler"}};
  ASSERT_EQ(reflection.msl->resources.size(), 3u);
  for (const MslResource& resource : reflection.msl->resources) {
    const std::string& name = resource.name;
    EXPECT_FALSE(name.empty());
    std::string attribute = "[[" + expected.at(resource.kind) + "(" + std::to_string(resource.index) + ")]]";
    EXPECT_NE(fragment->msl.find(attribute), std::string_view::npos) << name << " " << attribute << "\n" << fragment->msl;
  }
}

// Explicit fp16 stays 16-bit in SPIR-V and MSL, and becomes mediump 32-bit floats in GLSL ES (and plain floats
// in GLSL 450), so that GL drivers without a 16-bit float extension accept it.
TEST_F(SmallLibrary, HalfPrecisionIsWidenedToMediumpForGlOnly) {
  dir.write("S.hlsl",
            "float4 V(float4 p : POSITION) : SV_Position { return p; }\n"
            "float4 F(float4 p : SV_Position) : SV_Target {\n"
            "  half x = (half)p.x;\n  half3 c = half3(x, x * (half)0.5, (half)sqrt((float)x)) * (half)1.5;\n"
            "  return float4((float3)c, 1.0);\n}\n");
  DiagnosticSink sink;
  ASSERT_TRUE(build(dir / "p.pack.json", dir / "out", std::nullopt, 2, sink).ok) << errors_of(sink);
  PackReader pack = PackReader::open(dir / "out");
  const StageView* fragment = pack.variant("P", 0).stage("fragment");
  ASSERT_NE(fragment, nullptr);
  const uint32_t float16_capability[] = {(2u << 16) | 17u, 9u};  // OpCapability Float16
  std::string_view needle(reinterpret_cast<const char*>(float16_capability), sizeof float16_capability);
  EXPECT_NE(fragment->spirv.find(needle), std::string_view::npos);
  EXPECT_NE(fragment->msl.find("half"), std::string_view::npos);
  EXPECT_NE(fragment->gles.find("mediump"), std::string_view::npos) << fragment->gles;
  for (std::string_view gl : {fragment->gles, fragment->glsl}) {
    EXPECT_EQ(gl.find("float16_t"), std::string_view::npos) << gl;
    EXPECT_EQ(gl.find("FP16"), std::string_view::npos) << gl;
  }
}

// The MSL output has no compiler on Linux; what can be checked is that the manifest's MSL records are the
// entry point's resource arguments: the same [[buffer(n)]], [[texture(n)]] and [[sampler(n)]] attributes, each
// argument declared for the resource the record names (as its type, e.g. `constant PerFrame&`, or as its
// name), and every named resource one the stage's SPIR-V reflection lists. Returns the problems found.
std::vector<std::string> msl_record_problems(const StageView& stage) {
  std::vector<std::string> problems;
  const std::string msl(stage.msl);
  const size_t entry = msl.find(" " + stage.entry_point + "(");
  const size_t open = entry == std::string::npos ? entry : msl.find('(', entry);
  const size_t close = open == std::string::npos ? open : msl.find(")\n", open);
  if (close == std::string::npos) return {"no entry point '" + stage.entry_point + "' in the MSL"};
  // Arguments: "type name [[attribute]]", split at commas outside template brackets.
  std::map<std::string, std::string> arguments;  // "buffer(0)" -> declaration
  std::string argument;
  int depth = 0;
  for (size_t i = open + 1; i <= close; ++i) {
    char c = msl[i];
    depth += (c == '<') - (c == '>');
    if ((c == ',' && depth == 0) || i == close) {
      for (const char* kind : {"[[buffer(", "[[texture(", "[[sampler("}) {
        size_t at = argument.find(kind);
        if (at == std::string::npos) continue;
        std::string key = argument.substr(at + 2, argument.find(")]]", at) - at - 1);
        arguments[key] = argument.substr(0, at);
      }
      argument.clear();
    } else {
      argument += c;
    }
  }
  std::set<std::string> declared;
  for (const Resource& r : stage.reflection->resources) declared.insert(r.name);
  size_t records = 0;
  if (!stage.reflection->msl) return {"the stage has no MSL records"};
  for (const MslResource& r : stage.reflection->msl->resources) {
    ++records;
    static const char* const kKinds[] = {"buffer", "texture", "sampler"};
    const std::string name = r.name, key = kKinds[static_cast<size_t>(r.kind)] + ("(" + std::to_string(r.index) + ")");
    auto found = arguments.find(key);
    if (found == arguments.end()) {
      problems.push_back(name + ": the MSL entry point has no [[" + key + "]] argument");
      continue;
    }
    const std::string& d = found->second;
    if (d.find(" " + name + "&") == std::string::npos && d.find(" " + name + " ") == std::string::npos &&
        d.find(" " + name + "_") == std::string::npos)
      problems.push_back(name + ": [[" + key + "]] is declared as '" + d + "'");
    if (!declared.count(name)) problems.push_back(name + ": not a resource of the stage's SPIR-V reflection");
  }
  if (records != arguments.size())
    problems.push_back(std::to_string(arguments.size()) + " resource arguments in the MSL, " + std::to_string(records) +
                       " records in the manifest");
  return problems;
}

// The CI job docs/lint.md advertises is green on kiln's own packs: every variants/*.pack.json lints clean under
// --werror. Over the cache golden.setup filled when it built each of them cold: the default pack's lint is
// then under a second, not a minute of compiling.
TEST(BundledLibrary, EveryBundledPackLintsCleanUnderWerror) {
  testing::TempDir dir;
  std::vector<std::filesystem::path> packs;
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(KILN_SOURCE_DIR) / "variants"))
    if (entry.path().string().ends_with(".pack.json")) packs.push_back(entry.path());
  std::sort(packs.begin(), packs.end());
  EXPECT_GE(packs.size(), 3u);
  for (const std::filesystem::path& pack : packs) {
    testing::RunResult r =
        testing::run_kiln({"lint", pack.string(), "--werror", "--cache", (std::filesystem::path(KILN_GOLDEN_WORK) / "cache").string()}, dir.path());
    EXPECT_EQ(r.exit_code, 0) << pack.filename() << ":\n" << r.err;
  }
}

// The bundled library: every variant of the default pack compiles to SPIR-V, GLSL, GLSL ES and MSL with no
// warning, every variant is selectable through the reader, every variant's MSL resource records match its
// MSL, and stripped combinations are clear errors.
// The local cache golden.setup filled when it built the same pack cold (the fixture): warnings come back with the
// cached results, and the cold build itself is golden.setup's (a failed build fails it).
TEST(BundledLibrary, DefaultPackBuildsWithoutWarningsAndEveryVariantIsSelectable) {
  testing::TempDir dir;
  DiagnosticSink sink;
  BuildReport report = build(std::filesystem::path(KILN_SOURCE_DIR) / "variants/lit.pack.json", dir / "out",
                             std::filesystem::path(KILN_GOLDEN_WORK) / "cache", 0, sink);
  ASSERT_TRUE(report.ok) << errors_of(sink);
  EXPECT_EQ(sink.warning_count(), 0) << errors_of(sink);
  EXPECT_GT(report.funnel.kept, 100u);
  PackReader pack = PackReader::open(dir / "out");
  size_t variants = 0;
  for (const std::string& pass : pack.passes()) {
    for (size_t i = 0; i < pack.variant_count(pass); ++i, ++variants) {
      SelectedVariant v = pack.variant(pass, i);
      SelectedVariant again = pack.select(pass, v.keywords, true);
      EXPECT_EQ(again.index, i);
      for (const StageView& stage : v.stages) {
        EXPECT_FALSE(stage.spirv.empty());
        EXPECT_FALSE(stage.glsl.empty());
        EXPECT_FALSE(stage.gles.empty());
        EXPECT_FALSE(stage.msl.empty());
        for (const std::string& problem : msl_record_problems(stage))
          ADD_FAILURE() << pass << " #" << i << " " << stage.stage << ": " << problem;
      }
    }
  }
  EXPECT_EQ(variants, report.funnel.kept);

  // Every keyword changes the compiled code of a stage it is declared for: some pair of variants that
  // differ only in that keyword (against the group's off value) has a different binary in such a stage.
  for (const ManifestPass& pass : pack.manifest().passes) {
    std::map<std::vector<std::string>, size_t> by_keywords;
    const std::vector<ManifestVariant>& all = pass.variants;
    for (size_t i = 0; i < all.size(); ++i) by_keywords[all[i].keywords] = i;
    for (const ManifestKeywordGroup& group : pass.keyword_groups) {
      for (const std::string& keyword : group.values) {
        if (keyword.empty()) continue;
        bool changes = false, compared = false;
        for (const auto& [keywords, index] : by_keywords) {
          if (std::find(keywords.begin(), keywords.end(), keyword) == keywords.end()) continue;
          std::vector<std::string> without;
          for (const std::string& k : keywords)
            if (k != keyword) without.push_back(k);
          auto other = by_keywords.find(without);
          if (other == by_keywords.end()) continue;
          compared = true;
          for (Stage stage : kAllStages) {
            if (!(group.stages & stage_bit(stage))) continue;
            const auto& mine = all[index].binaries;
            const auto& theirs = all[other->second].binaries;
            if (mine.count(stage) && mine.at(stage) != theirs.at(stage)) changes = true;
          }
          if (changes) break;
        }
        if (compared) {
          EXPECT_TRUE(changes) << pass.name << ": keyword " << keyword << " changes no code of its stages";
        }
      }
    }
  }
  // Forward+ needs per-pixel additional lights: the combination with per-vertex lights is stripped.
  try {
    pack.select("Forward", {"_FORWARD_PLUS", "_ADDITIONAL_LIGHTS_VERTEX"});
    FAIL() << "a stripped variant was selected";
  } catch (const PackError& e) {
    EXPECT_EQ(e.code(), PackError::Code::Stripped);
  }
}

}  // namespace
}  // namespace kiln

namespace kiln {
namespace {

TEST_F(SmallLibrary, StripReportSaysWhatEachRuleRemovedAndWhy) {
  dir.write("p.pack.json", R"({"name": "p", "include_dirs": ["lib"],
    "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}],
    "constraints": [{"keyword": "FOG", "requires": ["SHADOWS"], "reason": "fog only outdoors"}]})");
  dir.write("outdoor.json", R"({"name": "outdoor", "keywords": ["SHADOWS"]})");
  BuildOptions options;
  options.pack_file = dir / "p.pack.json";
  options.scene_files = {dir / "outdoor.json"};
  options.output_dir = dir / "out";
  options.worker_executable = KILN_WORKER_PATH;
  DiagnosticSink sink;
  BuildReport report = build_pack(options, sink);
  ASSERT_TRUE(report.ok) << errors_of(sink);
  ASSERT_EQ(report.strip_report.size(), 2u);
  EXPECT_EQ(report.strip_report[0].what, "constraint FOG requires [SHADOWS]");
  EXPECT_EQ(report.strip_report[0].count, "-1");  // [FOG] alone
  EXPECT_EQ(report.strip_report[0].reason, "fog only outdoors");
  EXPECT_EQ(report.strip_report[1].what, "scenes (1)");
  EXPECT_EQ(report.strip_report[1].count, "3 -> 2");  // the scene never enables FOG
}

TEST_F(SmallLibrary, TargetsCanBeNarrowedFromTheCommandLine) {
  BuildOptions options;
  options.pack_file = dir / "p.pack.json";
  options.output_dir = dir / "out";
  options.worker_executable = KILN_WORKER_PATH;
  options.targets = {Target::Glsl};
  DiagnosticSink sink;
  ASSERT_TRUE(build_pack(options, sink).ok) << errors_of(sink);
  PackReader pack = PackReader::open(dir / "out");
  SelectedVariant v = pack.variant("P", 0);
  EXPECT_FALSE(v.stages[0].spirv.empty());  // SPIR-V is always built: every target comes from it
  EXPECT_FALSE(v.stages[0].glsl.empty());
  EXPECT_TRUE(v.stages[0].msl.empty());
  EXPECT_TRUE(v.stages[0].gles.empty());
}

}  // namespace
}  // namespace kiln

namespace kiln {
namespace {

struct SemanticScenes : SmallLibrary {
  void SetUp() override {
    SmallLibrary::SetUp();
    dir.write("p.pack.json", R"({"name": "p", "include_dirs": ["lib"],
      "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}],
      "scene_features": {"shadows": {"false": [], "true": ["SHADOWS"]},
                         "fog_distance_m": {"0": [], "1-": ["FOG"]}}})");
  }
  std::optional<PlanListing> plan(const std::string& scene, DiagnosticSink& sink) {
    dir.write("scene.json", scene);
    BuildOptions options;
    options.pack_file = dir / "p.pack.json";
    options.scene_files = {dir / "scene.json"};
    return list_variants(options, sink);
  }
};

TEST_F(SemanticScenes, UsesAreMappedToKeywordsByThePack) {
  DiagnosticSink sink;
  auto listing = plan(R"({"name": "s", "uses": {"shadows": true, "fog_distance_m": 0}})", sink);
  ASSERT_TRUE(listing) << errors_of(sink);
  ASSERT_EQ(listing->variants.size(), 2u);  // SHADOWS may be on; FOG never
  EXPECT_EQ(listing->variants[1].keywords, std::vector<std::string>{"SHADOWS"});
  listing = plan(R"({"name": "s", "uses": {"shadows": false, "fog_distance_m": 250}})", sink);
  ASSERT_TRUE(listing) << errors_of(sink);
  ASSERT_EQ(listing->variants.size(), 2u);  // a count in the open range 1- enables FOG
  EXPECT_EQ(listing->variants[1].keywords, std::vector<std::string>{"FOG"});
}

TEST_F(SemanticScenes, UnknownFeatureSuggestsTheClosestAndUnmappedValueListsTheMapping) {
  DiagnosticSink sink;
  EXPECT_FALSE(plan(R"({"name": "s", "uses": {"shadow": true}})", sink));
  auto d = sink.diagnostics().at(0);
  EXPECT_EQ(d.id, DiagId::SceneProfile);
  EXPECT_EQ(d.message, "scene 's' uses feature 'shadow', which the pack's scene_features does not map");
  EXPECT_EQ(d.notes.at(0), "did you mean 'shadows'?");
  DiagnosticSink sink2;
  EXPECT_FALSE(plan(R"({"name": "s", "uses": {"shadows": "sometimes"}})", sink2));
  d = sink2.diagnostics().at(0);
  EXPECT_EQ(d.message, "scene 's': feature 'shadows' has no mapping for \"sometimes\"");
  EXPECT_EQ(d.notes.at(0), "the pack maps: false, true");
}

// A pack is switched by one rename, the manifest's. Killed right after its new archive is in place, a build
// leaves the previous pack whole; killed right after the manifest's rename, the new one; and the next build
// removes the archive no manifest names, also when it finds the pack up to date.
TEST(PackSwitch, ABuildKilledBetweenItsRenamesLeavesAWholePackAndTheNextBuildRemovesTheOrphan) {
  testing::TempDir dir;
  dir.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  auto write_shader = [&](const std::string& value) {
    dir.write("S.hlsl", "#pragma multi_compile_fragment _ A\nfloat4 V(float4 p : POSITION) : SV_Position { return p; }\n"
                        "float4 F() : SV_Target { return " + value + "; }\n");
  };
  auto kiln_build = [&](const char* fault) {
    if (fault) ::setenv("KILN_PACK_FAULT_INJECTION", fault, 1);
    testing::RunResult r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--cache", "cache", "-q"}, dir.path());
    ::unsetenv("KILN_PACK_FAULT_INJECTION");
    return r;
  };
  // What a game would load: the fragment SPIR-V of variant [A] (its hash, for readable failures), or the error.
  auto loaded = [&] {
    try {
      PackReader pack = PackReader::open(dir / "out");
      return "spirv " + hash128(pack.select("P", {"A"}).stage("fragment")->spirv).hex();
    } catch (const PackError& e) {
      return std::string("PackError: ") + e.what();
    }
  };
  auto archives = [&] {
    std::set<std::string> names;
    for (const auto& file : testing::files_below(dir / "out"))
      if (file.extension() == ".kpack") names.insert(file.filename().string());
    return names;
  };
  const int killed = 128 + SIGKILL;

  write_shader("0.25");
  ASSERT_EQ(kiln_build(nullptr).exit_code, 0);
  const std::string old_spirv = loaded(), old_manifest = testing::read_file(dir / "out/p.manifest.json");
  const std::set<std::string> old_archives = archives();
  ASSERT_EQ(old_archives.size(), 1u);

  write_shader("0.75");
  ASSERT_EQ(kiln_build("kill-after-archive").exit_code, killed);
  EXPECT_EQ(testing::read_file(dir / "out/p.manifest.json"), old_manifest);
  EXPECT_EQ(loaded(), old_spirv);
  EXPECT_EQ(archives().size(), 2u);

  ASSERT_EQ(kiln_build("kill-after-manifest").exit_code, killed);
  const std::string new_spirv = loaded();
  EXPECT_NE(new_spirv, old_spirv);
  EXPECT_EQ(new_spirv.rfind("PackError", 0), std::string::npos) << new_spirv;
  EXPECT_EQ(archives().size(), 2u);  // the previous archive, not yet removed

  ASSERT_EQ(kiln_build(nullptr).exit_code, 0);
  EXPECT_EQ(loaded(), new_spirv);
  const std::set<std::string> new_archives = archives();
  EXPECT_EQ(new_archives, std::set<std::string>{testing::archive_named_by(dir / "out/p.manifest.json").filename().string()});

  // An orphan left while the inputs went back to what the pack was built from: the up-to-date build removes it.
  write_shader("0.5");
  ASSERT_EQ(kiln_build("kill-after-archive").exit_code, killed);
  EXPECT_EQ(archives().size(), 2u);
  write_shader("0.75");
  const std::string manifest = testing::read_file(dir / "out/p.manifest.json");
  ASSERT_EQ(kiln_build(nullptr).exit_code, 0);
  EXPECT_EQ(testing::read_file(dir / "out/p.manifest.json"), manifest);
  EXPECT_EQ(archives(), new_archives);
  EXPECT_EQ(loaded(), new_spirv);
}

TEST(BundledScenes, StripTheDefaultPackToWhatTheyNeedAndCheckSceneFindsEveryVariant) {
  testing::TempDir dir;
  std::filesystem::path root = KILN_SOURCE_DIR;
  BuildOptions options;
  options.pack_file = root / "variants/lit.pack.json";
  options.output_dir = dir / "out";
  options.worker_executable = KILN_WORKER_PATH;
  for (const char* scene : {"outdoor_day", "night_city", "mobile"})
    options.scene_files.push_back(root / "variants/scenes" / (std::string(scene) + ".json"));
  DiagnosticSink sink;
  BuildReport report = build_pack(options, sink);
  ASSERT_TRUE(report.ok) << errors_of(sink);
  EXPECT_LT(report.funnel.kept, report.funnel.valid);
  EXPECT_LT(report.funnel.kept, 300u);
  PackReader pack = PackReader::open(dir / "out");
  for (const auto& scene : options.scene_files) {
    auto check = check_scene(pack, scene, sink);
    ASSERT_TRUE(check) << errors_of(sink);
    EXPECT_GT(check->requested, 0u);
    EXPECT_TRUE(check->missing.empty()) << scene << ": " << check->missing.size() << " missing";
  }
}

}  // namespace
}  // namespace kiln
