// SPDX-License-Identifier: Apache-2.0
#include <gtest/gtest.h>

#include <cstdlib>

#include <regex>

#include "cross/targets.hpp"
#include "frontend/frontend.hpp"
#include "optimize/spirv_tools.hpp"
#include "workers/worker_pool.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

CompileJob job(std::string source, std::string entry = "main") {
  CompileJob j;
  j.stage = Stage::Fragment;
  j.entry_point = std::move(entry);
  j.source_name = "test.hlsl";
  j.source = std::move(source);
  j.targets = {Target::Spirv, Target::Glsl, Target::Gles, Target::Msl};
  return j;
}

const char* kValid = "float4 main() : SV_Target { return float4(1.0, 0.5, 0.25, 1.0); }\n";
// glslang 12.0.0 segfaults on this (ARCHITECTURE.md).
const char* kCrash = "float4 main(float4) : SV_Target { return 0; }\n";

// `worker`: the shipped worker, or the tests' fault-injecting one (tests/support/fault_worker.cpp).
std::vector<WorkerOutcome> run_jobs(std::vector<CompileJob> jobs, WorkerLimits limits = {}, unsigned workers = 2,
                                    const char* worker = KILN_WORKER_PATH) {
  WorkerPool pool(worker, workers, limits);
  std::vector<WorkerOutcome> outcomes(jobs.size());
  pool.run(jobs, [&](size_t i, WorkerOutcome o) { outcomes[i] = std::move(o); });
  return outcomes;
}

// Everything after the front end sees only the Frontend interface. A front end that is not glslang (a stand-in
// that hands over a module glslang made earlier, under its own name and with its own warning) drives the same
// back end to the same outputs.
class StandInFrontend final : public Frontend {
 public:
  explicit StandInFrontend(std::vector<uint32_t> module) : module_(std::move(module)) {}
  std::string name() const override { return "stand-in"; }
  std::string version() const override { return "1"; }
  PreprocessResult preprocess(const PreprocessRequest& request) override {
    return {true, std::string(request.entry_text), {}};
  }
  CompileResult compile(const CompileRequest& request) override {
    CompileResult result;
    result.ok = true;
    result.spirv = module_;
    result.messages.push_back({Severity::Warning, request.source_name, 1, "stand-in front end"});
    return result;
  }

 private:
  std::vector<uint32_t> module_;
};

// Cache keys name the exact tools: each version comes from the library kiln links (SPIRV-Cross, which has
// no run-time version, from its C API header and a hash of its library files), never from a package manager.
TEST(Workers, EveryToolVersionInTheCacheKeysComesFromTheLinkedLibraries) {
  EXPECT_TRUE(std::regex_match(spirv_cross_version(), std::regex(R"(C API \d+\.\d+\.\d+, libraries sha256 [0-9a-f]{16})")))
      << spirv_cross_version();
  EXPECT_EQ(spirv_cross_version(), spirv_cross_version());
  EXPECT_TRUE(std::regex_search(spirv_tools_version(), std::regex(R"(^v\d{4}\.\d+)"))) << spirv_tools_version();  // spvSoftwareVersionString
  EXPECT_EQ(make_frontend("glslang")->version().rfind("12.", 0), 0u) << make_frontend("glslang")->version();
}

TEST(Workers, AnotherFrontEndDrivesTheSameBackEnd) {
  EXPECT_EQ(frontend_names(), std::vector<std::string>{"glslang"});
  EXPECT_EQ(make_frontend("dxc"), nullptr);
  auto glslang = make_frontend("glslang");
  ASSERT_NE(glslang, nullptr);
  EXPECT_EQ(glslang->name(), "glslang");

  CompileJob front = job(kValid);
  front.kind = JobKind::FrontEnd;
  JobOutput module = run_compile_job(*glslang, front);
  ASSERT_TRUE(module.ok) << step_name(module.failed_step);
  StandInFrontend stand_in(module.spirv);

  const CompileJob full = job(kValid);
  JobOutput expected = run_compile_job(*glslang, full);
  JobOutput got = run_compile_job(stand_in, full);
  ASSERT_TRUE(expected.ok && got.ok) << step_name(got.failed_step);
  ASSERT_EQ(got.blobs.size(), 4u);
  for (const auto& [target, blob] : expected.blobs)
    EXPECT_EQ(got.blobs.at(target), blob) << target_name(target);
  EXPECT_EQ(got.reflection, expected.reflection);
  ASSERT_EQ(got.messages.size(), 1u);
  EXPECT_EQ(got.messages[0].text, "stand-in front end");
}

TEST(Workers, CompileProducesEveryTarget) {
  auto outcomes = run_jobs({job(kValid)});
  ASSERT_EQ(outcomes[0].kind, WorkerOutcome::Kind::Done);
  ASSERT_TRUE(outcomes[0].output.ok) << step_name(outcomes[0].output.failed_step);
  const auto& blobs = outcomes[0].output.blobs;
  EXPECT_EQ(unpack_spirv(blobs.at(Target::Spirv)).at(0), 0x07230203u);
  EXPECT_NE(unpack_blob(blobs.at(Target::Glsl)).find("#version 450"), std::string::npos);
  EXPECT_NE(unpack_blob(blobs.at(Target::Gles)).find("#version 310 es"), std::string::npos);
  EXPECT_NE(unpack_blob(blobs.at(Target::Msl)).find("#include <metal_stdlib>"), std::string::npos);
  // Packed where they were compiled: the text targets as zstd frames.
  EXPECT_TRUE(blobs.at(Target::Msl).compressed());
}

// The build's two halves: a FrontEnd job returns the glslang module; a BackEnd job appended from on_done
// (as the pipeline does for each new module) runs in the same pool and finishes the compile.
TEST(Workers, BackEndAppendedByOnDoneFinishesWhatTheFrontEndStarted) {
  std::vector<CompileJob> jobs{job(kValid), job(kValid)};
  jobs[0].kind = JobKind::FrontEnd;
  jobs[1].kind = JobKind::Full;
  WorkerPool pool(KILN_WORKER_PATH, 2, {});
  std::vector<WorkerOutcome> outcomes(3);
  pool.run(jobs, [&](size_t i, WorkerOutcome o) {
    if (i == 0 && o.output.ok) {
      CompileJob back = jobs[0];
      back.kind = JobKind::BackEnd;
      back.source.clear();
      back.spirv = o.output.spirv;
      jobs.push_back(std::move(back));
    }
    outcomes.at(i) = std::move(o);
  });
  ASSERT_EQ(jobs.size(), 3u);
  ASSERT_TRUE(outcomes[0].output.ok);
  EXPECT_TRUE(outcomes[0].output.blobs.empty());  // a front end stops at the module
  ASSERT_TRUE(outcomes[2].output.ok) << step_name(outcomes[2].output.failed_step);
  ASSERT_TRUE(outcomes[1].output.ok);
  // Front end + back end gives what one Full job gives.
  EXPECT_EQ(outcomes[2].output.blobs, outcomes[1].output.blobs);
}

TEST(Workers, GlslangCrashCostsOneJobAndTheOthersStillBuild) {
  auto outcomes = run_jobs({job(kValid), job(kCrash), job(kValid), job(kValid)}, {}, 1);
  EXPECT_EQ(outcomes[0].kind, WorkerOutcome::Kind::Done);
  EXPECT_EQ(outcomes[1].kind, WorkerOutcome::Kind::Crashed);
  EXPECT_NE(outcomes[1].detail.find("signal 11"), std::string::npos) << outcomes[1].detail;
  EXPECT_EQ(outcomes[2].kind, WorkerOutcome::Kind::Done);
  EXPECT_TRUE(outcomes[3].output.ok);
}

// Many jobs, several crashes among them, two workers respawned as they die: every job gets exactly its own
// outcome, whatever the order of completion.
TEST(Workers, AmongCrashesEveryJobGetsItsOwnOutcome) {
  std::vector<CompileJob> jobs;
  for (int i = 0; i < 24; ++i) {
    if (i % 5 == 3) {
      jobs.push_back(job(kCrash));
    } else {
      jobs.push_back(job("float4 main() : SV_Target { return float4(" + std::to_string(100 + i) + ".0, 0.0, 0.0, 1.0); }\n"));
    }
  }
  auto outcomes = run_jobs(jobs, {}, 2);
  for (int i = 0; i < 24; ++i) {
    if (i % 5 == 3) {
      EXPECT_EQ(outcomes[i].kind, WorkerOutcome::Kind::Crashed) << i;
      continue;
    }
    ASSERT_EQ(outcomes[i].kind, WorkerOutcome::Kind::Done) << i << ": " << outcomes[i].detail;
    ASSERT_TRUE(outcomes[i].output.ok) << i;
    EXPECT_NE(unpack_blob(outcomes[i].output.blobs.at(Target::Glsl)).find(std::to_string(100 + i) + ".0"), std::string::npos)
        << "job " << i << " got another job's result";
  }
}

TEST(Workers, MissingEntryPointIsAnErrorNotAWarning) {
  auto outcomes = run_jobs({job(kValid, "Mian")});
  ASSERT_EQ(outcomes[0].kind, WorkerOutcome::Kind::Done);
  EXPECT_FALSE(outcomes[0].output.ok);
  EXPECT_EQ(outcomes[0].output.failed_step, CompileStep::EntryPoint);
}

// A worker preprocesses from the files a job carries, by the includes the declaration scan resolved in each:
// never from the file system, and a name the scan did not resolve is refused.
TEST(Workers, PreprocessingServesIncludesOnlyFromTheJobsFiles) {
  testing::TempDir dir;
  dir.write("Outside.hlsl", "float outside_of_the_job() { return 1.0; }\n");
  auto files = std::make_shared<std::vector<IncludableFile>>(std::vector<IncludableFile>{
      {"Main.hlsl", "#include \"Lib.hlsl\"\nfloat4 main() : SV_Target { return LIB_VALUE; }\n", false, {{"Lib.hlsl", "lib/Lib.hlsl"}}},
      {"lib/Lib.hlsl", "#pragma once\n#define LIB_VALUE float4(KEYWORD, 0, 0, 1)\n", true, {}},
  });
  CompileJob good;
  good.kind = JobKind::Preprocess;
  good.files = files;
  good.defines = {"KEYWORD"};
  CompileJob outside = good;
  outside.files = std::make_shared<std::vector<IncludableFile>>(std::vector<IncludableFile>{
      {"Main.hlsl", "#include \"" + (dir / "Outside.hlsl").string() + "\"\nfloat4 main() : SV_Target { return 1; }\n", false, {}}});
  auto outcomes = run_jobs({good, outside});
  ASSERT_EQ(outcomes[0].kind, WorkerOutcome::Kind::Done);
  EXPECT_TRUE(outcomes[0].output.ok);
  EXPECT_NE(outcomes[0].output.preprocessed.find("return float4(1, 0, 0, 1);"), std::string::npos) << outcomes[0].output.preprocessed;
  EXPECT_EQ(outcomes[0].output.files_read, (std::vector<std::string>{"lib/Lib.hlsl", "Main.hlsl"}));
  ASSERT_EQ(outcomes[1].kind, WorkerOutcome::Kind::Done);
  EXPECT_FALSE(outcomes[1].output.ok);
  EXPECT_EQ(outcomes[1].output.failed_step, CompileStep::Preprocess);
  ASSERT_FALSE(outcomes[1].output.messages.empty());
  EXPECT_NE(outcomes[1].output.messages[0].text.find("was not seen by the declaration scan"), std::string::npos)
      << outcomes[1].output.messages[0].text;
}

TEST(Workers, HungWorkerIsKilledAtTheTimeout) {
  WorkerLimits limits;
  // The clock starts when the worker is spawned, so a good job's time includes a worker start-up
  // (loading glslang, SPIRV-Tools, SPIRV-Cross): generous, as only the hung job waits it out.
  limits.job_timeout = std::chrono::seconds(10);
  // One worker: the jobs after the hung one run in the worker started to replace it.
  auto outcomes = run_jobs({job(kValid), job(std::string("// kiln-fault: hang\n") + kValid), job(kValid), job(kValid)}, limits, 1,
                           KILN_FAULT_WORKER_PATH);
  EXPECT_EQ(outcomes[0].kind, WorkerOutcome::Kind::Done);
  EXPECT_EQ(outcomes[1].kind, WorkerOutcome::Kind::TimedOut);
  EXPECT_EQ(outcomes[2].kind, WorkerOutcome::Kind::Done);
  EXPECT_TRUE(outcomes[3].output.ok);
}

// Fault injection lives in the tests' own worker: the shipped worker and CLI hold none of its triggers.
TEST(Workers, TheShippedWorkerHasNoFaultInjection) {
  for (const char* executable : {KILN_WORKER_PATH, KILN_CLI_PATH}) {
    const std::string bytes = testing::read_file(executable);
    ASSERT_GT(bytes.size(), 100000u) << executable;
    for (const char* trigger : {"kiln-fault: hang", "kiln-fault: oom", "kiln-fault: crash-preprocess", "kiln_fault_throw",
                                "KilnFaultCrashBackEnd"})
      EXPECT_EQ(bytes.find(trigger), std::string::npos) << executable << " holds " << trigger;
  }
  EXPECT_NE(testing::read_file(KILN_FAULT_WORKER_PATH).find("kiln-fault: hang"), std::string::npos);
}

TEST(Workers, WorkerOverItsMemoryLimitIsAnInternalError) {
  WorkerLimits limits;
  limits.memory_limit_mb = 512;
  auto outcomes = run_jobs({job(std::string("// kiln-fault: oom\n") + kValid), job(kValid), job(kValid)}, limits, 1,
                           KILN_FAULT_WORKER_PATH);
  EXPECT_EQ(outcomes[0].kind, WorkerOutcome::Kind::OutOfMemory);
  EXPECT_EQ(outcomes[1].kind, WorkerOutcome::Kind::Done);
  EXPECT_TRUE(outcomes[2].output.ok);
}

// The compile workers are where the allocator matters (bench/REPORT.md, "The cold build"): they must be running on
// the one the build was configured with, and with mimalloc an allocation past the limit must still throw
// (WorkerOverItsMemoryLimitIsAnInternalError above), not abort.
TEST(Workers, WorkerRunsOnTheConfiguredAllocator) {
  std::string version = testing::run({KILN_WORKER_PATH, "--version"}, std::filesystem::temp_directory_path()).out;
  EXPECT_NE(version.find(KILN_EXPECT_MIMALLOC ? "allocator: mimalloc 2." : "allocator: glibc malloc"), std::string::npos)
      << version;
  EXPECT_EQ(version.find("not serving"), std::string::npos) << version;
}

}  // namespace
}  // namespace kiln
