// SPDX-License-Identifier: Apache-2.0
// Stage 4: the stage sources of a build. One per (pass, stage, keywords the stage sees), preprocessed once
// however many variants share it (in the compiler workers, under their limits), or not at all when a
// preprocessing memo in the cache says what it would give; then deduplicated by content into binaries, the
// unit the compile stage works on. A build streams them: the compile stage (driver/compile) sends each source's
// Preprocess job and compiles it as soon as it is preprocessed; dedupe_stage_sources then numbers the binaries
// in source order, as if every source had been preprocessed first.
#pragma once

#include <array>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cache/cache.hpp"
#include "common/hash.hpp"
#include "driver/messages.hpp"
#include "driver/plan.hpp"
#include "driver/settings.hpp"
#include "workers/job_runner.hpp"
#include "workers/worker_pool.hpp"

namespace kiln {

struct StageSource {
  uint32_t pass = 0;
  Stage stage = Stage::Vertex;
  std::vector<std::string> defines;  // the keywords the stage sees, then its folded keywords' macros
  size_t first_variant = 0;          // for messages
  // Declarations of the stage's folded keywords (kiln/folded_keywords.hpp), put before the preprocessed text.
  std::shared_ptr<const std::string> folded;
  bool ok = false;
  bool preprocessed = false;  // text holds the preprocessed source (not only known through a memo)
  bool elsewhere = false;     // another shard's (--shard): not preprocessed, not compiled here, no binary
  std::string text;
  std::vector<FrontendMessage> messages;
  int binary = -1;
  std::optional<Hash128> key;           // the source's cache key: from the text, or from a memo
  Hash128 memo;                         // where its preprocessing memo is cached
  std::vector<std::string> files_read;  // display names, when preprocessed in this build
  // -g: the files it read, its entry first, as the build read them: the module's OpSource holds them, and its key.
  std::shared_ptr<const std::vector<IncludableFile>> debug_files;
  std::string internal_error;           // the worker preprocessing it crashed: how
  std::vector<std::string> internal_notes;  // then: where its reproducer is (or why it could not be written)
};

struct StageSources {
  std::vector<StageSource> list;
  // variant_source[pass][variant][stage]: index into `list`, or -1 when the pass has no such stage.
  std::vector<std::vector<std::array<int, kStageCount>>> variant_source;
  std::map<std::string, uint64_t> file_hashes;  // display name -> XXH3 of the text, for preprocessing memos
  std::chrono::steady_clock::time_point enumerated_from;  // when the preprocess stage started (its timing)
  uint64_t stage_instances = 0;  // variants x the stages of their pass (the funnel's), before dedupe
  size_t memo_hits = 0;          // sources not preprocessed: what they read is unchanged since their memo
};

// One distinct preprocessed source (with its stage and entry point): one front end, one compile.
struct Binary {
  Hash128 key;
  Stage stage = Stage::Vertex;
  std::string entry_point;
  size_t source = 0;  // a StageSource that produced it
  std::vector<size_t> sources;
  std::shared_ptr<const JobOutput> output;  // shared by every binary whose front end gave the same module
};

std::string variant_description(const Plan& plan, const StageSource& source);

// A file name for a set of keywords: "_FOG+_SHADOWS", "_" for none (--emit dumps, reproducers).
std::string keywords_slug(const std::vector<std::string>& keywords);

// Runs Preprocess jobs: each pass's files travel with its jobs (the worker never reads the file system).
class Preprocessor {
 public:
  // `limits`: the workers' (messages name them); a worker's death leaves its reproducer in `build.reproducers`.
  Preprocessor(const Plan& plan, const BuildSettings& settings, JobRunner& runner, const BuildContext& build,
               WorkerLimits limits);
  // Preprocesses `which` (indexes into sources.list); sets text, messages, files read and key of each.
  void run(StageSources& sources, const std::vector<size_t>& which);
  // The same, one job at a time, for a caller that runs the jobs itself: source `index`'s Preprocess job, and
  // what its outcome says of the source.
  CompileJob job(const StageSources& sources, size_t index);
  void finished(StageSource& source, WorkerOutcome outcome) const;

 private:
  // The files a stage's preprocessing may read, its own entry file first.
  std::shared_ptr<const std::vector<IncludableFile>> files_of(uint32_t pass, Stage stage);
  // Of those, the ones `source` read (its Preprocess job was made, so they are known), without their includes.
  std::shared_ptr<const std::vector<IncludableFile>> files_read(const StageSource& source) const;
  // A worker died or threw while preprocessing `source`: its entry file with the job's defines written before it,
  // in <output>/kiln-ice/, as compile.cpp writes one for a death in a compile.
  void write_reproducer(StageSource& source) const;

  const Plan& plan_;
  const BuildSettings& settings_;
  JobRunner& runner_;
  const BuildContext& build_;
  WorkerLimits limits_;
  std::vector<std::array<std::shared_ptr<const std::vector<IncludableFile>>, kStageCount>> pass_files_;
};

// How many distinct stage sources the plan's variants have (what a cold build preprocesses; folded groups counted
// as one module): enumerate_stage_sources without the memos.
size_t count_stage_sources(const Plan& plan);

// Enumerates the stage sources of every variant and takes what the cache's memos know (a source with a key
// and no text). `cache`: nothing, or the cache whose memos to use (not with --emit preprocessed: its text is
// wanted).
StageSources enumerate_stage_sources(const Plan& plan, const BuildSettings& settings, Cache* memo_cache);

// enumerate_stage_sources, then preprocesses every source the memos do not know, all before returning (for
// tools and tests that want the texts; a build streams them into its compiles instead).
StageSources prepare_stage_sources(BuildContext& build, const Plan& plan, const BuildSettings& settings,
                                   Cache* memo_cache, Preprocessor& preprocessor);

// Reports why a stage source did not preprocess: its first error only (after one, glslang's preprocessor stops,
// and what it reports next, like "missing #endif" after an #error, cascades from it); a crash is an internal
// compiler error.
void report_preprocess_failure(const StageSource& source, size_t order, const Plan& plan, const SourceLocator& locator,
                               MessageGroups& messages, DiagnosticSink& sink);

// Which share of `count` each stage source falls in (--shard I/N), from what is known before preprocessing: the
// sources in order of pass, then stage, then identity hash (source_identity), dealt out in turn, so that each share
// holds a near-equal number of each pass's vertex and fragment sources with no pattern in their keywords, and every
// machine with the same plan deals the same shares.
std::vector<uint32_t> source_shares(const StageSources& sources, unsigned count);

// A stage source by what names it before preprocessing (pass, stage, defines, folded declarations), for checking that
// another machine's record of a source is about the same source.
uint64_t source_identity(const StageSource& source);

// Deduplicates the preprocessed sources by key into binaries; reports those that did not preprocess.
std::vector<Binary> dedupe_stage_sources(BuildContext& build, StageSources& sources, const Plan& plan,
                                         const SourceLocator& locator, MessageGroups& messages);

}  // namespace kiln
