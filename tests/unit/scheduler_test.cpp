// SPDX-License-Identifier: Apache-2.0
// The build's compile scheduler (driver/compile) run against an in-process JobRunner: no worker processes, and
// the test decides in which order jobs finish.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <deque>
#include <set>

#include "driver/compile.hpp"
#include "driver/result_store.hpp"
#include "driver/plan.hpp"
#include "driver/settings.hpp"
#include "driver/stage_sources.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

// Answers each job the way the test says; runs them first-in-first-out or last-in-first-out (a stand-in for
// "whichever worker finishes first"), follow-up jobs included.
class FakeRunner final : public JobRunner {
 public:
  enum class Order { Fifo, Lifo };
  std::function<WorkerOutcome(const CompileJob&)> answer;
  Order order = Order::Fifo;
  std::vector<CompileJob> seen;

  void run(std::vector<CompileJob>& jobs, const std::function<void(size_t, WorkerOutcome)>& on_done,
           const ExternalWork* external) override {
    std::deque<size_t> pending;
    for (size_t j = 0; j < jobs.size(); ++j) pending.push_back(j);
    while (!pending.empty() || (external && external->pending())) {
      if (pending.empty()) {  // only outside work left: wait for it
        pollfd fd{external->fd, POLLIN, 0};
        ::poll(&fd, 1, -1);
        const size_t before = jobs.size();
        external->arrived();
        for (size_t added = before; added < jobs.size(); ++added) pending.push_back(added);
        continue;
      }
      size_t j = order == Order::Fifo ? pending.front() : pending.back();
      if (order == Order::Fifo) pending.pop_front();
      else pending.pop_back();
      seen.push_back(jobs[j]);
      const size_t before = jobs.size();
      on_done(j, answer(jobs[j]));
      for (size_t added = before; added < jobs.size(); ++added) pending.push_back(added);
    }
  }
  unsigned spawned() const override { return 0; }

  size_t count(JobKind kind) const {
    return static_cast<size_t>(std::count_if(seen.begin(), seen.end(), [&](const CompileJob& j) { return j.kind == kind; }));
  }
};

WorkerOutcome done(JobOutput output) {
  WorkerOutcome outcome;
  outcome.output = std::move(output);
  return outcome;
}

// Preprocessing gives a text per (stage, keywords); every front end of a stage gives that stage's one module
// (the keyword's code is never reached); back ends succeed.
WorkerOutcome default_answer(const CompileJob& job) {
  JobOutput out;
  out.ok = true;
  if (job.kind == JobKind::Preprocess) {
    out.preprocessed = std::string(stage_name(job.stage)) + " " + join_keywords(job.defines);
  } else if (job.kind == JobKind::FrontEnd) {
    out.spirv = {0x07230203u, job.stage == Stage::Vertex ? 1u : 2u};
  } else {
    out.blobs[Target::Spirv] = pack_spirv(job.spirv);
  }
  return done(std::move(out));
}

class Scheduler : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_.write("S.hlsl", "#pragma multi_compile _ A B\nfloat4 V() : SV_Position { return 0; }\nfloat4 F() : SV_Target { return 0; }\n");
    dir_.write("p.pack.json", R"({"name": "p", "passes": [{"name": "P", "source": "S.hlsl", "stages": {"vertex": "V", "fragment": "F"}}]})");
    options_.pack_file = dir_ / "p.pack.json";
    options_.output_dir = dir_ / "out";
    plan_ = make_plan(options_, *build_);
    ASSERT_TRUE(plan_);
    settings_ = choose_settings(options_, *plan_, *sink_);
    ASSERT_TRUE(settings_);
  }

  // Stages 4-7 (first half) against `runner`, as build_pack runs them.
  // `store`: nothing, a store with no tier (nothing is ever found).
  CompileResults compile(FakeRunner& runner, ResultStore* store = nullptr) {
    Preprocessor preprocessor(*plan_, *settings_, runner, *build_, WorkerLimits{});
    SourceLocator locator(*plan_);
    sources_ = enumerate_stage_sources(*plan_, *settings_, nullptr);
    std::unique_ptr<ResultStore> empty = make_result_store(*plan_, *settings_, StoreTiers{});
    CompileResults results = compile_stage_sources(*build_, *plan_, *settings_, Shard{}, sources_,
                                                   CompileServices{runner, store ? *store : *empty, preprocessor},
                                                   locator, messages_);
    binaries_ = results.binaries;
    counts_ = results.counts;
    return results;
  }

  std::string reported() {
    messages_.report(*sink_);
    std::string text;
    for (const Diagnostic& d : sink_->diagnostics()) text += format_diagnostic(d);
    return text;
  }

  void reset() {
    sink_ = std::make_unique<DiagnosticSink>();
    build_ = std::make_unique<BuildContext>(*sink_, dir_ / "out" / "kiln-ice");
    counts_ = CompileCounts();
    messages_ = MessageGroups();
  }

  testing::TempDir dir_;
  BuildOptions options_;
  std::unique_ptr<DiagnosticSink> sink_ = std::make_unique<DiagnosticSink>();
  std::unique_ptr<BuildContext> build_ = std::make_unique<BuildContext>(*sink_, dir_ / "out" / "kiln-ice");
  CompileCounts counts_;
  std::unique_ptr<Plan> plan_;
  std::optional<BuildSettings> settings_;
  StageSources sources_;
  std::vector<Binary> binaries_;
  MessageGroups messages_;
};

TEST_F(Scheduler, RunsOneBackEndPerDistinctModuleAndSharesItsOutput) {
  FakeRunner runner;
  runner.answer = default_answer;
  CompileResults results = compile(runner);
  EXPECT_EQ(runner.count(JobKind::Preprocess), 6u);  // 3 variants x 2 stages, each stage sees the keyword
  EXPECT_EQ(runner.count(JobKind::FrontEnd), 6u);
  EXPECT_EQ(runner.count(JobKind::BackEnd), 2u);  // one module per stage
  EXPECT_EQ(counts_.back_ends, 2u);
  EXPECT_EQ(results.unique_modules, 2u);
  ASSERT_EQ(results.modules.size(), 2u);
  std::set<const JobOutput*> vertex, fragment;  // every binary of a stage shares its module's one output
  for (const Binary& b : binaries_) {
    ASSERT_TRUE(b.output) << b.entry_point;
    (b.stage == Stage::Vertex ? vertex : fragment).insert(b.output.get());
  }
  EXPECT_EQ(vertex.size(), 1u);
  EXPECT_EQ(fragment.size(), 1u);
  EXPECT_NE(*vertex.begin(), *fragment.begin());
  EXPECT_FALSE(sink_->has_errors()) << reported();
}

TEST_F(Scheduler, TheOrderInWhichJobsFinishChangesNothing) {
  FakeRunner fifo, lifo;
  fifo.answer = lifo.answer = [](const CompileJob& job) {
    if (job.kind == JobKind::FrontEnd && job.source.find(" A") != std::string::npos) {
      JobOutput out;
      out.failed_step = CompileStep::Frontend;
      out.messages = {{Severity::Error, "S.hlsl", 2, "'x' : undeclared identifier"}};
      return done(std::move(out));
    }
    return default_answer(job);
  };
  lifo.order = FakeRunner::Order::Lifo;
  compile(fifo);
  const std::string first = reported();
  std::vector<bool> first_outputs;
  for (const Binary& b : binaries_) first_outputs.push_back(b.output != nullptr);

  reset();
  compile(lifo);
  EXPECT_EQ(reported(), first);
  std::vector<bool> second_outputs;
  for (const Binary& b : binaries_) second_outputs.push_back(b.output != nullptr);
  EXPECT_EQ(second_outputs, first_outputs);
  EXPECT_NE(first.find("error[K1401]"), std::string::npos) << first;
  EXPECT_NE(first.find("and in 1 more variant(s)"), std::string::npos) << first;  // A in both stages: grouped
}

TEST_F(Scheduler, ABackEndDeathIsAnInternalErrorOfEveryBinaryWaitingOnItsModule) {
  FakeRunner runner;
  runner.answer = [](const CompileJob& job) {
    if (job.kind == JobKind::BackEnd && job.stage == Stage::Fragment) {
      WorkerOutcome crashed;
      crashed.kind = WorkerOutcome::Kind::Crashed;
      crashed.detail = "was killed by signal 11 (Segmentation fault)";
      return crashed;
    }
    return default_answer(job);
  };
  compile(runner);
  EXPECT_TRUE(sink_->contains(DiagId::InternalCompilerError));
  size_t fragment_without_output = 0, vertex_with_output = 0;
  for (const Binary& b : binaries_) {
    if (b.stage == Stage::Fragment && !b.output) ++fragment_without_output;
    if (b.stage == Stage::Vertex && b.output) ++vertex_with_output;
  }
  EXPECT_EQ(fragment_without_output, 3u);
  EXPECT_EQ(vertex_with_output, 3u);
  EXPECT_EQ(sink_->error_count(), 3);  // one internal compiler error per variant, each with its reproducer
  EXPECT_TRUE(std::filesystem::exists(dir_ / "out" / "kiln-ice" / "P.fragment.A.hlsl"));
  EXPECT_TRUE(std::filesystem::exists(dir_ / "out" / "kiln-ice" / "P.fragment.A.spv"));
}

TEST_F(Scheduler, FailedStepsAreReportedWithTheirDiagnostic) {
  struct Case {
    CompileStep step;
    const char* name;
    const char* id;
  };
  for (const Case& c : {Case{CompileStep::Validate, "validate", "K1403"}, Case{CompileStep::Legalize, "legalize", "K1404"},
                        Case{CompileStep::Optimize, "optimize", "K1404"},
                        Case{CompileStep::ValidateOptimized, "validate-optimized", "K1403"},
                        Case{CompileStep::CrossMsl, "cross-msl", "K1405"}}) {
    SCOPED_TRACE(c.name);
    reset();
    FakeRunner runner;
    runner.answer = [&](const CompileJob& job) {
      if (job.kind == JobKind::BackEnd && job.stage == Stage::Fragment) {
        JobOutput out;
        out.failed_step = c.step;
        out.messages = {{Severity::Error, "", 0, "something is wrong"}};
        return done(std::move(out));
      }
      return default_answer(job);
    };
    compile(runner);
    const std::string text = reported();
    EXPECT_NE(text.find(std::string("error[") + c.id + "]: " + c.name + ": something is wrong"), std::string::npos) << text;
    EXPECT_FALSE(sink_->contains(DiagId::InternalCompilerError));
  }
}

TEST_F(Scheduler, AModuleTheCacheHasRunsNoBackEnd) {
  Cache cache(dir_ / "cache");
  FakeRunner first;
  first.answer = default_answer;
  std::unique_ptr<ResultStore> store = make_result_store(*plan_, *settings_, StoreTiers{&cache});
  CompileResults results = compile(first, store.get());
  store->keep(*build_, results, sources_, false);
  ASSERT_FALSE(sink_->has_errors()) << reported();

  // The same sources: found whole, nothing runs. A new keyword's sources: front ends only, their modules known.
  dir_.write("S.hlsl", "#pragma multi_compile _ A B C\nfloat4 V() : SV_Position { return 0; }\nfloat4 F() : SV_Target { return 0; }\n");
  plan_ = make_plan(options_, *build_);
  ASSERT_TRUE(plan_);
  FakeRunner second;
  second.answer = default_answer;
  store = make_result_store(*plan_, *settings_, StoreTiers{&cache});
  compile(second, store.get());
  EXPECT_EQ(counts_.cache_hits, 6u);
  EXPECT_EQ(second.count(JobKind::FrontEnd), 2u);  // C, per stage
  EXPECT_EQ(second.count(JobKind::BackEnd), 0u);
  EXPECT_EQ(counts_.back_end_hits, 2u);
  for (const Binary& b : binaries_) EXPECT_TRUE(b.output);
}

// A store whose tier answers later, while the workers run (as the remote does): it has every vertex source's result,
// no fragment source's. Its answers come through an eventfd the runner polls. With `hold_misses` it says its misses
// only when asked to finish (--remote-required).
class SlowStore final : public ResultStore {
 public:
  explicit SlowStore(bool hold_misses) : hold_misses_(hold_misses), fd_(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)) {}
  ~SlowStore() override { ::close(fd_); }
  std::optional<StoredResult> find(const Hash128&) override { return std::nullopt; }
  std::optional<JobOutput> find_module(const Hash128&, const StageSource&, const std::vector<uint32_t>&) override {
    return std::nullopt;
  }
  bool ask(size_t ticket, const StageSource& source) override {
    asked_.emplace_back(ticket, source.stage);
    const uint64_t one = 1;
    EXPECT_EQ(::write(fd_, &one, sizeof one), static_cast<ssize_t>(sizeof one));
    return true;
  }
  std::vector<Answer> answers() override {
    uint64_t count = 0;
    [[maybe_unused]] ssize_t got = ::read(fd_, &count, sizeof count);
    std::vector<Answer> answers;
    for (auto [ticket, stage] : asked_) {
      if (stage == Stage::Fragment && hold_misses_) {
        held_.push_back(ticket);
        continue;
      }
      answers.push_back({ticket, std::nullopt});
      if (stage == Stage::Vertex) {
        JobOutput output;
        output.ok = true;
        output.messages = {{Severity::Warning, "", 0, "from the slow tier"}};
        StoredResult found{std::make_shared<const JobOutput>(std::move(output)), Hash128{7, 7}};
        answers.back().found = std::move(found);
      }
    }
    asked_.clear();
    return answers;
  }
  size_t outstanding() const override { return asked_.size(); }
  int ready_fd() const override { return fd_; }
  std::vector<Answer> finish(DiagnosticSink&) override {
    ++finished_;
    std::vector<Answer> answers = this->answers();
    for (size_t ticket : held_) answers.push_back({ticket, std::nullopt});
    held_.clear();
    return answers;
  }
  size_t keep(BuildContext&, const CompileResults&, const StageSources&, bool) override { return 0; }
  void upload(BuildContext&, const CompileResults&, bool) override {}
  int finished_ = 0;

 private:
  bool hold_misses_;
  int fd_;
  std::vector<std::pair<size_t, Stage>> asked_;
  std::vector<size_t> held_;
};

TEST_F(Scheduler, TheStoresLaterAnswersSettleTheirKeysAndItsMissesAreCompiled) {
  for (bool hold_misses : {false, true}) {
    SCOPED_TRACE(hold_misses ? "misses held until finish" : "misses answered at once");
    reset();
    SlowStore store(hold_misses);
    FakeRunner runner;
    runner.answer = default_answer;
    compile(runner, &store);
    EXPECT_EQ(store.finished_, 1);
    EXPECT_EQ(runner.count(JobKind::Preprocess), 6u);
    ASSERT_EQ(runner.count(JobKind::FrontEnd), 3u);  // the fragment sources only
    for (const CompileJob& job : runner.seen) {
      if (job.kind != JobKind::Preprocess) {
        EXPECT_EQ(job.stage, Stage::Fragment);
      }
    }
    ASSERT_EQ(binaries_.size(), 6u);
    for (const Binary& b : binaries_) {
      ASSERT_TRUE(b.output);
      const bool from_store = !b.output->messages.empty() && b.output->messages[0].text == "from the slow tier";
      EXPECT_EQ(from_store, b.stage == Stage::Vertex);
    }
    EXPECT_FALSE(sink_->has_errors()) << reported();
  }
}

// Streaming: a source's front end is sent as soon as it is preprocessed, while later sources still wait for
// theirs. LIFO finishes the last job sent first, so a front end queued by the stream runs before the remaining
// Preprocess jobs; compiling only after preprocessing would send every Preprocess job first.
TEST_F(Scheduler, FrontEndsAreSentWhileOtherSourcesAreStillBeingPreprocessed) {
  FakeRunner runner;
  runner.answer = default_answer;
  runner.order = FakeRunner::Order::Lifo;
  compile(runner);
  auto last_preprocess = std::find_if(runner.seen.rbegin(), runner.seen.rend(),
                                      [](const CompileJob& j) { return j.kind == JobKind::Preprocess; });
  auto first_front_end = std::find_if(runner.seen.begin(), runner.seen.end(),
                                      [](const CompileJob& j) { return j.kind == JobKind::FrontEnd; });
  ASSERT_NE(first_front_end, runner.seen.end());
  EXPECT_LT(first_front_end - runner.seen.begin(), runner.seen.rend() - last_preprocess - 1);
  EXPECT_EQ(runner.count(JobKind::Preprocess), 6u);
  EXPECT_EQ(runner.count(JobKind::FrontEnd), 6u);
  for (const Binary& b : binaries_) EXPECT_TRUE(b.output) << b.entry_point;
  EXPECT_FALSE(sink_->has_errors()) << reported();
}

// A source that fails to preprocess stops nothing else: the others compile, and the failure is reported as an
// unstreamed build reports it, whichever order the jobs finish in.
TEST_F(Scheduler, APreprocessingFailureDoesNotStopTheOtherSourcesCompiles) {
  auto answer = [](const CompileJob& job) {
    if (job.kind == JobKind::Preprocess && std::find(job.defines.begin(), job.defines.end(), "A") != job.defines.end() &&
        job.stage == Stage::Fragment) {
      JobOutput out;
      out.failed_step = CompileStep::Preprocess;
      out.messages = {{Severity::Error, "S.hlsl", 1, "#error A is broken"}};
      return done(std::move(out));
    }
    return default_answer(job);
  };
  std::string first;
  for (FakeRunner::Order order : {FakeRunner::Order::Fifo, FakeRunner::Order::Lifo}) {
    reset();
    FakeRunner runner;
    runner.answer = answer;
    runner.order = order;
    compile(runner);
    EXPECT_EQ(runner.count(JobKind::FrontEnd), 5u);  // every source but the broken one
    EXPECT_EQ(binaries_.size(), 5u);
    for (const Binary& b : binaries_) EXPECT_TRUE(b.output) << b.entry_point;
    const std::string text = reported();
    EXPECT_NE(text.find("error[K1408]"), std::string::npos) << text;
    EXPECT_NE(text.find("A is broken"), std::string::npos) << text;
    if (first.empty()) first = text;
    EXPECT_EQ(text, first);
  }
}

// Stage sources whose preprocessed texts are the same are one compile, even when the duplicate is preprocessed
// after its twin's front end was sent (or finished); binaries are numbered in source order either way.
TEST_F(Scheduler, ADuplicateSourceArrivingLateIsNotCompiledAgain) {
  auto answer = [](const CompileJob& job) {
    if (job.kind == JobKind::Preprocess) {  // keyword B changes no code: "" and "B" preprocess alike
      std::vector<std::string> seen_keywords;
      for (const std::string& d : job.defines)
        if (d != "B") seen_keywords.push_back(d);
      JobOutput out;
      out.ok = true;
      out.preprocessed = std::string(stage_name(job.stage)) + " " + join_keywords(seen_keywords);
      return done(std::move(out));
    }
    return default_answer(job);
  };
  std::vector<std::vector<size_t>> numbering;
  for (FakeRunner::Order order : {FakeRunner::Order::Fifo, FakeRunner::Order::Lifo}) {
    reset();
    FakeRunner runner;
    runner.answer = answer;
    runner.order = order;
    compile(runner);
    EXPECT_EQ(runner.count(JobKind::Preprocess), 6u);
    EXPECT_EQ(runner.count(JobKind::FrontEnd), 4u);  // per stage: none-or-B, A
    EXPECT_EQ(counts_.compiled, 4u);
    ASSERT_EQ(binaries_.size(), 4u);
    std::vector<size_t> sources_of;
    for (const Binary& b : binaries_) {
      EXPECT_TRUE(b.output) << b.entry_point;
      sources_of.push_back(b.source);
      EXPECT_EQ(b.source, b.sources.front());  // the first source of its key, not the first to arrive
    }
    for (const StageSource& s : sources_.list) EXPECT_GE(s.binary, 0);
    numbering.push_back(sources_of);
    EXPECT_FALSE(sink_->has_errors()) << reported();
  }
  EXPECT_EQ(numbering[0], numbering[1]);
}

}  // namespace
}  // namespace kiln
