// SPDX-License-Identifier: Apache-2.0
// `kiln build --trace FILE`: the file read back as the Trace Event Format specifies it (complete events with numeric
// ts and dur, metadata naming every track, slices on a track nested or disjoint), and holding what it promises (every
// stage source's preprocess and front end, every back end's steps, the driver's stages). No assertion on a time
// beyond order and nesting. The worker protocol's step times are checked as the rest of a worker's answer is.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>

#include <nlohmann/json.hpp>

#include "common/compile_result.hpp"
#include "driver/build_trace.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

using nlohmann::json;

struct Slice {
  std::string name, category;
  int64_t ts = 0, dur = 0;
  json args;
  int64_t end() const { return ts + dur; }
  bool contains(const Slice& other) const { return ts <= other.ts && other.end() <= end(); }
};
using Track = std::pair<int64_t, int64_t>;  // pid, tid

struct ReadTrace {
  std::map<Track, std::string> track_names;
  std::map<Track, std::vector<Slice>> tracks;  // sorted by start, the longer first
};

// Reads the file as the format says, failing the test on anything the format does not allow.
ReadTrace read_trace(const std::filesystem::path& file) {
  ReadTrace trace;
  const json document = json::parse(testing::read_file(file));
  EXPECT_TRUE(document.at("traceEvents").is_array());
  for (const json& event : document.at("traceEvents")) {
    EXPECT_TRUE(event.at("name").is_string()) << event.dump();
    EXPECT_TRUE(event.at("pid").is_number_integer() && event.at("tid").is_number_integer()) << event.dump();
    const Track track{event.at("pid").get<int64_t>(), event.at("tid").get<int64_t>()};
    const std::string phase = event.at("ph").get<std::string>();
    if (phase == "M") {
      EXPECT_TRUE(event.at("args").at("name").is_string()) << event.dump();
      if (event.at("name") == "thread_name") trace.track_names[track] = event.at("args").at("name").get<std::string>();
      continue;
    }
    EXPECT_EQ(phase, "X") << "every slice is a complete event: " << event.dump();
    EXPECT_TRUE(event.at("ts").is_number() && event.at("dur").is_number()) << event.dump();
    Slice slice{event.at("name").get<std::string>(), event.value("cat", ""), event.at("ts").get<int64_t>(),
                event.at("dur").get<int64_t>(), event.value("args", json::object())};
    EXPECT_GE(slice.ts, 0) << event.dump();
    EXPECT_GE(slice.dur, 0) << event.dump();
    trace.tracks[track].push_back(std::move(slice));
  }
  for (auto& [track, slices] : trace.tracks) {
    EXPECT_TRUE(trace.track_names.count(track)) << "track " << track.first << "/" << track.second << " has no thread_name";
    std::stable_sort(slices.begin(), slices.end(),
                     [](const Slice& a, const Slice& b) { return a.ts != b.ts ? a.ts < b.ts : a.dur > b.dur; });
    // Nested or disjoint: each slice inside the innermost one still open, or after it.
    std::vector<const Slice*> open;
    for (const Slice& slice : slices) {
      while (!open.empty() && open.back()->end() <= slice.ts) open.pop_back();
      if (!open.empty()) {
        EXPECT_TRUE(open.back()->contains(slice))
            << "'" << slice.name << "' [" << slice.ts << ", " << slice.end() << "] overlaps '" << open.back()->name
            << "' [" << open.back()->ts << ", " << open.back()->end() << "] in part on track " << trace.track_names[track];
      }
      open.push_back(&slice);
    }
  }
  return trace;
}

// The steps inside a job's slice, on its track.
std::vector<std::string> steps_of(const std::vector<Slice>& track, const Slice& job) {
  std::vector<std::string> steps;
  for (const Slice& slice : track)
    if (slice.category == "step" && job.contains(slice)) steps.push_back(slice.name);
  return steps;
}

struct BuildTraceFile : ::testing::Test {
  testing::TempDir dir;
  void SetUp() override {
    // Two stage sources per stage (each stage's own keyword): four preprocesses, four front ends, four back ends.
    dir.write("S.hlsl", "#pragma multi_compile_vertex _ WIDE\n#pragma multi_compile_fragment _ SUN\n"
                        "struct VSOut { float4 pos : SV_Position; float3 dir : TEXCOORD0; };\n"
                        "VSOut V(float3 p : POSITION) {\n  VSOut o;\n  o.pos = float4(p.xy, 1, 1);\n"
                        "#ifdef WIDE\n  o.dir = p * 2;\n#else\n  o.dir = p;\n#endif\n  return o;\n}\n"
                        "float4 F(VSOut i) : SV_Target {\n  float3 c = i.dir;\n#ifdef SUN\n  c += pow(saturate(i.dir.y), 64);\n"
                        "#endif\n  return float4(c, 1);\n}\n");
    dir.write("p.pack.json", R"({"name": "sky", "targets": ["spirv", "glsl", "gles", "msl"], "passes": [{"name": "Sky",
        "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
  }
};

TEST_F(BuildTraceFile, EveryStageSourceHasItsPreprocessAndFrontEndAndEveryBackEndItsStepsOnNestedWorkerTracks) {
  auto r = testing::run_kiln({"build", "p.pack.json", "-o", "out", "--no-cache", "-j", "2", "--trace", "trace.json", "-q"},
                             dir.path());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const ReadTrace trace = read_trace(dir / "trace.json");
  if (HasFailure()) return;

  // The driver's stages, on its tracks.
  std::set<std::string> stages;
  for (const auto& [track, slices] : trace.tracks)
    if (track.first == 1)
      for (const Slice& slice : slices)
        if (slice.category == "stages") stages.insert(slice.name);
  for (const char* stage : {"plan", "load", "preprocess", "compile", "reflect", "pack", "total"})
    EXPECT_TRUE(stages.count(stage)) << "no '" << stage << "' stage on the driver's tracks";

  // The plan's stage sources: (stage, the keywords it sees), from `kiln list`.
  std::set<std::pair<std::string, json>> expected;
  const json listed = json::parse(testing::run_kiln({"list", "p.pack.json", "--json"}, dir.path()).out);
  for (const json& variant : listed.at("variants"))
    for (const auto& [stage, keywords] : variant.at("stages").items()) expected.emplace(stage, keywords);
  ASSERT_EQ(expected.size(), 4u) << listed.dump();

  // Every worker track named for its slot; each job's stage source and steps.
  std::map<std::string, std::set<std::pair<std::string, json>>> sources_by_job;  // "preprocess", "front end"
  size_t back_ends = 0;
  for (const auto& [track, slices] : trace.tracks) {
    if (track.first != 2) continue;
    EXPECT_EQ(trace.track_names.at(track), "worker " + std::to_string(track.second));
    for (const Slice& job : slices) {
      if (job.category != "job") continue;
      const std::string kind = job.args.at("job").get<std::string>();
      const std::vector<std::string> steps = steps_of(slices, job);
      if (kind == "preprocess") {
        EXPECT_EQ(steps, std::vector<std::string>{"preprocess"}) << job.name;
      } else if (kind == "front end") {
        EXPECT_EQ(steps, std::vector<std::string>{"frontend"}) << job.name;
      } else {
        EXPECT_EQ(kind, "back end") << job.name;
        EXPECT_EQ(steps, (std::vector<std::string>{"legalize", "optimize", "reflect", "cross-glsl", "cross-gles", "cross-msl"}))
            << job.name;
        ++back_ends;
        continue;
      }
      EXPECT_EQ(job.args.at("pass"), "Sky") << job.name;
      sources_by_job[kind].emplace(job.args.at("stage").get<std::string>(), job.args.at("keywords"));
    }
  }
  EXPECT_EQ(sources_by_job["preprocess"], expected) << "every stage source is preprocessed once, in a worker";
  EXPECT_EQ(sources_by_job["front end"], expected) << "every stage source's front end ran, in a worker";
  EXPECT_EQ(back_ends, 4u);
}

TEST_F(BuildTraceFile, AWarmBuildIsOneCacheLookupPerStageSourceAndNoWorkerJob) {
  auto cold = testing::run_kiln({"build", "p.pack.json", "-o", "cold", "--cache", "cache", "-q"}, dir.path());
  ASSERT_EQ(cold.exit_code, 0) << cold.err;
  auto warm = testing::run_kiln({"build", "p.pack.json", "-o", "warm", "--cache", "cache", "--trace", "trace.json", "-q"},
                                dir.path());
  ASSERT_EQ(warm.exit_code, 0) << warm.err;
  const ReadTrace trace = read_trace(dir / "trace.json");
  std::set<std::pair<std::string, json>> found;
  for (const auto& [track, slices] : trace.tracks) {
    EXPECT_EQ(track.first, 1) << "a job ran in a worker: " << slices.front().name;
    for (const Slice& slice : slices)
      if (slice.name == "cache lookup") {
        EXPECT_EQ(trace.track_names.at(track), "cache lookups");
        EXPECT_EQ(slice.args.at("found"), true) << slice.args.dump();
        found.emplace(slice.args.at("stage").get<std::string>(), slice.args.at("keywords"));
      }
  }
  EXPECT_EQ(found.size(), 4u) << testing::read_file(dir / "trace.json");
}

// A worker's step times are an untrusted answer, as the rest of it: bounded, known steps, in order; and the cache's
// encoding of the same output never holds a time.
TEST(WorkerStepTimes, AreCheckedOnDecodeAndNeverCached) {
  JobOutput output;
  output.ok = true;
  output.steps = {{CompileStep::Frontend, 0, 10}, {CompileStep::Legalize, 10, 5}};
  output.steps_elapsed_us = 20;
  const JobOutput back = decode_output(encode_output(output, /*with_steps=*/true));
  ASSERT_EQ(back.steps.size(), 2u);
  EXPECT_EQ(back.steps[1].step, CompileStep::Legalize);
  EXPECT_EQ(back.steps[1].start_us, 10u);
  EXPECT_TRUE(decode_output(encode_output(output)).steps.empty());

  auto rejected = [&](std::vector<StepSpan> steps) {
    JobOutput bad = output;
    bad.steps = std::move(steps);
    EXPECT_THROW(decode_output(encode_output(bad, true)), std::exception);
  };
  rejected({{CompileStep::Frontend, 0, 10}, {CompileStep::Legalize, 5, 5}});  // overlapping
  rejected({{CompileStep::None, 0, 10}});                                      // not a step
  rejected({{CompileStep::Frontend, uint64_t{1} << 62, 1}});                  // past any build
  rejected(std::vector<StepSpan>(kMaxStepSpans + 1, StepSpan{CompileStep::Reflect, 0, 0}));  // too many
  rejected({{CompileStep::Frontend, 0, 30}});  // ends after the job did in the worker (20 us)
}

// The driver's slices go on as few tracks as nesting allows: a stage that overlaps another in part (compile streaming
// after preprocess) takes a second track; one inside another stays on its track.
TEST(TraceLayout, AStageOverlappingAnotherInPartGoesOnASecondTrackAndNestedOnesStay) {
  const StageClock::time_point start = StageClock::now();
  auto at = [&](int us) { return start + std::chrono::microseconds(us); };
  kiln::BuildTrace trace("unused.json", start);
  trace.driver_slice("stages", "total", at(0), at(100));
  trace.driver_slice("stages", "preprocess", at(10), at(60));
  trace.driver_slice("stages", "compile", at(30), at(100));
  trace.driver_slice("stages", "dedupe", at(61), at(62));
  std::map<std::string, int> tid;
  const json document = json::parse(trace.to_json());
  for (const json& event : document.at("traceEvents"))
    if (event.at("ph") == "X") tid[event.at("name").get<std::string>()] = event.at("tid").get<int>();
  EXPECT_EQ(tid, (std::map<std::string, int>{{"total", 0}, {"preprocess", 0}, {"dedupe", 0}, {"compile", 1}}));
}

// A worker's steps are placed from the job's arrival in the worker (the answer less the worker's time on it, never
// before the send) and clamped to its answer: a worker that claims a step longer than the job (or one starting after
// it) cannot make a slice stick out of its job.
TEST(TraceLayout, AWorkersStepsStayInsideItsJobWhateverItClaims) {
  const StageClock::time_point start = StageClock::now();
  JobTiming timing;
  timing.slot = 3;
  timing.sent = start + std::chrono::microseconds(1000);
  timing.answered = start + std::chrono::microseconds(2000);
  timing.steps = {{CompileStep::Frontend, 0, 400}, {CompileStep::Legalize, 400, 10'000'000}, {CompileStep::Optimize, 50'000, 1}};
  timing.steps_elapsed_us = 10'000'000;  // more than the job took: its steps start at the send
  kiln::BuildTrace trace("unused.json", start);
  trace.worker_job(timing, "front end: x", json::object());
  // A first job that waited 600 us for its worker to start: its steps begin 600 us after the send.
  JobTiming first = timing;
  first.slot = 4;
  first.steps = {{CompileStep::Preprocess, 0, 300}};
  first.steps_elapsed_us = 400;
  trace.worker_job(first, "preprocess: y", json::object());
  std::map<std::string, std::pair<int64_t, int64_t>> slices;
  bool named = false;
  const json document = json::parse(trace.to_json());
  for (const json& event : document.at("traceEvents")) {
    if (event.at("ph") == "M" && event.at("pid") == 2 && event.at("tid") == 3) named = event.at("args").at("name") == "worker 3";
    if (event.at("ph") != "X") continue;
    slices[event.at("name").get<std::string>()] = {event.at("ts").get<int64_t>(), event.at("dur").get<int64_t>()};
  }
  EXPECT_TRUE(named);
  using Span = std::pair<int64_t, int64_t>;
  EXPECT_EQ(slices.at("front end: x"), (Span{1000, 1000}));
  EXPECT_EQ(slices.at("frontend"), (Span{1000, 400}));
  EXPECT_EQ(slices.at("legalize"), (Span{1400, 600}));
  EXPECT_EQ(slices.at("optimize"), (Span{2000, 0}));
  EXPECT_EQ(slices.at("preprocess: y"), (Span{1000, 1000}));
  EXPECT_EQ(slices.at("preprocess"), (Span{1600, 300}));
}

}  // namespace
}  // namespace kiln
