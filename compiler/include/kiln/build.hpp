// SPDX-License-Identifier: Apache-2.0
// kiln's library entry points: plan (stages 1-3), build (stages 1-8) and the build report.
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "kiln/defaults.hpp"
#include "kiln/diagnostics.hpp"
#include "kiln/manifest.hpp"
#include "kiln/model.hpp"
#include "kiln/version.hpp"  // generated from CMake's project version (cmake/version.hpp.in)

namespace kiln {

// What `--emit` can dump, one name per pipeline stage, in the pipeline's order: the variants, the preprocessed HLSL,
// each target's code (its row's emit stage in kiln/targets.def: spvasm, glsl, msl) and the reflection.
inline const std::set<std::string>& emit_stage_names() {
  static const std::set<std::string> names = [] {
    std::set<std::string> all{"variants", "preprocessed", "reflection"};
    for (const TargetName& target : kTargetNames) all.emplace(target.emit);
    return all;
  }();
  return names;
}
inline std::string emit_stage_list() {
  std::string list = "variants, preprocessed";
  std::set<std::string_view> listed;
  for (const TargetName& target : kTargetNames)
    if (listed.insert(target.emit).second) list += ", " + std::string(target.emit);
  return list + ", reflection";
}

// The shared remote cache under the local one (docs/remote-cache.md): the Bazel HTTP cache protocol.
struct RemoteCacheOptions {
  std::string url;                                  // http(s)://host[:port][/path]; empty: no remote
  std::string instance;                             // path prefix under the URL (like Bazel's instance name)
  std::string key_namespace;                        // mixed into every key: caches apart on one server
  bool upload = false;                              // write what this build compiled (read-only otherwise)
  bool required = false;                            // remote errors fail the build (CI shard jobs)
  std::chrono::milliseconds connect_timeout = defaults::kRemoteConnectTimeout;  // a server that is down costs at most this, once
  std::chrono::milliseconds operation_timeout = defaults::kRemoteTimeout;      // one request, transfer included
  std::string bearer_token;                         // sent as "Authorization: Bearer"; never printed
  std::filesystem::path token_file;                 // read when bearer_token is empty
  std::filesystem::path ca_file;                    // empty: the system's CAs
  std::filesystem::path netrc_file;                 // basic auth; empty: libcurl's default (~/.netrc)
  unsigned parallel_transfers = defaults::kRemoteParallelTransfers;  // requests in flight (one kept-alive connection each)
};

struct BuildOptions {
  std::filesystem::path pack_file;
  std::vector<std::filesystem::path> scene_files;
  // --usage: keep only the variants these usage logs asked for (docs/usage.md), the logs with every tag of
  // `usage_tags` (--usage-tag KEY=VALUE), plus those `usage_margin` keyword groups away (--usage-margin).
  std::vector<std::filesystem::path> usage_logs;
  std::vector<std::pair<std::string, std::string>> usage_tags;
  unsigned usage_margin = 0;
  std::filesystem::path output_dir;
  unsigned jobs = 0;                                // 0: one worker per core
  std::optional<std::filesystem::path> cache_dir;  // nothing: no cache
  uint64_t cache_max_mb = defaults::kCacheMaxMb;    // least recently used segments go past this
  std::set<std::string> emit;                       // stages to dump under <output>/emit/
  std::optional<std::filesystem::path> depfile;
  // --trace: the build's stages, worker jobs and their steps, and cache lookups as Chrome Trace Event Format JSON
  // (docs/build-trace.md), written whether the build succeeds or not.
  std::optional<std::filesystem::path> trace_file;
  std::filesystem::path worker_executable;          // empty: default_worker_executable()
  std::chrono::milliseconds worker_timeout = defaults::kWorkerTimeout;
  uint64_t worker_memory_limit_mb = defaults::kWorkerMemoryLimitMb;
  bool optimize = true;
  // Debug information in the SPIR-V (kiln compile -g): OpSource with the preprocessed HLSL text, OpLine and names,
  // as glslangValidator -g writes them (RenderDoc shows the source). Best with `optimize` off.
  bool debug_info = false;
  // Shader code coverage (kiln build --coverage, docs/coverage.md): every SPIR-V module instrumented; the build
  // turns debug information on and optimization off.
  bool coverage = false;
  OptimizerRecipe optimizer_recipe = OptimizerRecipe::Kiln;  // --optimize=kiln|O (with `optimize`)
  std::string frontend = "glslang";                 // HLSL front end, by name (frontend_names())
  std::vector<Target> targets;                      // empty: the pack definition's targets
  uint64_t max_file_bytes = defaults::kMaxFileBytes;
  BindingOptions bindings;       // command line: overrides every pass's "bindings" field by field
  std::vector<Define> defines;   // command line (-D): added to every pass's, replacing a define of the same name
  // command line (--keyword-kind): keyword -> the kind its group is built as, over the pack's "keyword_kinds"
  std::map<std::string, KeywordKind> keyword_kinds;
  RemoteCacheOptions remote;
  // --shard I/N: preprocess and compile only share I of N of the stage sources (dealt out before preprocessing, the
  // same on every machine), keep them in the caches, and upload them with one bundle of the whole share. The shard
  // that finds every other shard's bundle on the server assembles and writes the pack; otherwise a build without a
  // shard, the merge, writes it from the bundles.
  unsigned shard_index = 0;
  unsigned shard_count = 1;
  std::function<void(size_t done, size_t total, size_t cache_hits)> progress;
  bool keep_plan = false;                           // fill BuildReport::plan (lint observes the build's plan)
  // Something outside the build that may end it early (kiln watch: an edit, a variant request, a signal). The
  // workers' scheduler also waits on `fds` and calls `check()` on the build's thread when one of them is readable
  // (it must read what made it so) and before it hands out a job; once `check()` says true (and it must keep
  // saying so), no job is handed out any more: those in flight finish and their results go into the cache, the
  // others are not run, and the build ends with BuildReport::cancelled, writing no pack.
  struct Interruption {
    std::vector<int> fds;
    std::function<bool()> check;
  } interruption;
};

// declared -> valid -> after scene stripping -> unique per stage -> compiles -> modules -> unique binaries
// The funnel the manifest records (kiln/manifest.hpp), and whether the declared count saturated (the summary's).
struct Funnel : ManifestFunnel {
  bool declared_saturated = false;
};

// One variant, as `kiln list` shows it.
struct VariantListing {
  std::string pass;
  std::vector<std::string> keywords;
  std::vector<std::pair<std::string, std::vector<std::string>>> stage_keywords;  // stage -> keywords it sees
};
// Per pass: the binding options and defines in effect (pack, pass and command line combined).
struct PassSettings {
  std::string pass;
  BindingOptions bindings;
  std::vector<Define> defines;
};
struct PlanListing {
  std::string pack;
  Funnel funnel;
  std::vector<VariantListing> variants;
  std::vector<PassSettings> pass_settings;
  // For lint: each pass's keyword groups (with where they are declared), every source file read
  // (display path -> text), and the keywords each scene may enable.
  std::vector<std::pair<std::string, std::vector<KeywordGroup>>> pass_groups;
  std::vector<std::pair<std::string, std::string>> sources;
  std::vector<std::pair<std::string, std::set<std::string>>> scenes;
  std::vector<SourceLocation> pass_locations;  // where each pass (as in pass_groups) is defined in the pack file
  size_t stage_sources = 0;  // distinct stage sources (pass, stage, keywords it sees): what a cold build preprocesses
  // For lint: the pack's include roots (the library whose other shaders' keywords a shared header may test) and
  // its "lint": {"disable": [...]} rules.
  std::vector<std::filesystem::path> include_dirs;
  std::vector<std::string> lint_disable;
};

// Per pass: what each constraint removes on its own (with its reason), then materials and scenes.
struct StripLine {
  std::string pass;
  std::string what;     // "constraint _SHADOWS_SOFT requires_any [...]", "materials", "scenes"
  std::string count;    // variants removed, or "n -> m"
  std::string reason;
};

struct StageTiming {
  std::string stage;
  double milliseconds = 0;
  double start_ms = 0;  // since the build started; stages that stream together overlap (preprocess, compile)
  double end_ms = 0;
};

// What one compiler worker slot did, in milliseconds since the build started (a slot whose worker died is
// restarted in place: one slot).
struct WorkerTimeline {
  double spawned_ms = 0;                   // its first process started
  double first_compile_ms = -1;            // its first front or back end was handed to it; -1: none
  double idle_before_first_compile_ms = 0;  // from spawned_ms to first_compile_ms, less the preprocessing in between
  double last_done_ms = 0;                 // its last job finished
  double preprocess_busy_ms = 0;           // with a Preprocess job in flight
  double compile_busy_ms = 0;              // with a front or back end in flight
  double idle_ms = 0;                      // from spawned_ms to last_done_ms with no job in flight
  size_t jobs = 0;
};

// What the remote cache tier did; every count is of requests that were answered.
struct RemoteReport {
  bool configured = false;     // a remote was given
  bool switched_off = false;   // errors turned it off for the rest of the build (or it was never usable)
  bool pack_fetched = false;   // the finished pack of these inputs came from the remote (nothing else done)
  size_t hits = 0;             // stage sources fetched whole (nothing compiled)
  size_t misses = 0;           // stage sources asked for and not found (a failed request included)
  size_t incomplete = 0;       // entries found in part: a record or blob they name is gone (evicted, an upload cut
                               // short); a plain miss, which an uploading build puts back
  size_t uploads = 0;          // records written (results and aliases)
  size_t blobs_uploaded = 0;
  size_t repaired = 0;         // module entries put again whole: this build found them missing or damaged
  size_t shard_bundles = 0;    // shards' bundles used (a merge, or the shard that finished last)
  size_t shard_sources = 0;    // stage sources whose result came from a shard's bundle
  uint64_t bytes_down = 0;
  uint64_t bytes_up = 0;
  size_t errors = 0;           // failed requests and entries that failed verification
};

struct BuildReport {
  bool ok = false;
  bool up_to_date = false;          // nothing changed: no work done
  bool internal_errors = false;     // a worker crashed/hung/ran out of memory
  bool cancelled = false;           // BuildOptions::interruption ended it: no pack written (`ok` is false)
  Funnel funnel;
  std::vector<StageTiming> timings;
  std::vector<WorkerTimeline> worker_timeline;  // one per worker slot, when workers ran
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();  // timings count from here
  std::vector<StripLine> strip_report;
  size_t compiled = 0;              // stage sources compiled (front ends run)
  size_t back_ends = 0;             // back ends run: one per distinct front-end module not in the cache
  size_t back_end_hits = 0;         // front-end modules whose back end was in the cache
  size_t full_legalizations = 0;    // back ends run whose module needed SPIRV-Tools' full legalization recipe
  size_t cache_hits = 0;            // stage sources found whole in the cache (nothing run)
  size_t preprocess_memo_hits = 0;  // stage sources not preprocessed: what they read is unchanged
  size_t cache_rejected = 0;
  unsigned workers_started = 0;
  RemoteReport remote;
  size_t shard_skipped = 0;         // stage sources left to the other shards (--shard)
  bool shard_assembled = false;     // a shard that finished last wrote the pack
  std::filesystem::path manifest;
  std::vector<std::filesystem::path> dependencies;  // every input file read
  std::optional<PlanListing> plan;                  // stages 0-3's result, with BuildOptions::keep_plan
};

// Builds a pack. Every problem goes to `sink`; the report says what was done.
BuildReport build_pack(const BuildOptions& options, DiagnosticSink& sink);

// Stages 0-3 only, as `kiln list` shows them.
std::optional<PlanListing> list_variants(const BuildOptions& options, DiagnosticSink& sink);

// A Makefile-syntax depfile: the manifest depends on every input read. False (reported) when it cannot be written.
bool write_depfile(const std::filesystem::path& depfile, const std::filesystem::path& manifest,
                   const std::vector<std::filesystem::path>& dependencies, DiagnosticSink& sink);

// The names `--frontend` takes ("glslang").
std::vector<std::string> frontend_names();

// What kiln compiles with, a line each, for --version and bug reports: each front end and its version, SPIRV-Tools,
// the optimizer recipes, SPIRV-Cross (its C API version and the fingerprint of its libraries).
std::string toolchain_description();

// The CLI's exit status: 0 ok, else the worst exit class of the errors (diagnostics.def): 1 input, 2 internal (also
// when `internal_errors`), 3 environment.
int exit_code(const DiagnosticSink& sink, bool internal_errors);

}  // namespace kiln
