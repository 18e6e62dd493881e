// SPDX-License-Identifier: Apache-2.0
// One unit of work for a compiler worker: a preprocessed stage source in, every target out.
// Runs inside a worker process, because glslang can crash on some inputs.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/compile_step.hpp"
#include "frontend/frontend.hpp"
#include "kiln/model.hpp"

namespace kiln {

// Part of every cache key: bump it whenever a compile job's output changes for the same input and tool
// versions (kiln's own version does not change between commits). 2: GL targets widen 16-bit floats, name
// blocks by their interface name, and pair texel fetches with a dummy sampler. 3: MSL records name resources
// as declared (not as SPIRV-Cross renamed a colliding variable). 4: legalization by the core recipe first
// (the same code, other ID numbers), outputs record which recipe legalized them. 5: outputs are packed blobs
// (zstd frames made by the worker). 6: preprocessed text keeps character literals, 1.#INF and string escapes
// (memoized source keys of older builds name the wrong text); block sizes are reflected in 64 bits.
// 7: outputs reflect the HLSL semantic of each input and output (frontend/interface_semantics.hpp).
inline constexpr int kCompileJobRevision = 7;

// A compile runs in two halves so that stage sources which differ only in code the entry point never
// reaches (a fragment-only keyword's branch in a file the vertex stage also includes) are legalized,
// optimized and cross-compiled once: the build hashes each front end's SPIR-V and sends one back end per
// distinct module. Full does both halves in one job.
// Preprocess runs the front end's preprocessor in a worker too: a macro that expands exponentially, or files
// that include each other again and again, then cost that worker its memory or time limit, never kiln itself.
enum class JobKind { Full, FrontEnd, BackEnd, Preprocess };

// A file a Preprocess job may include, with the includes the declaration scan resolved in it. The worker
// serves #include from these only: the build's one snapshot of each file, confined to the include roots.
struct IncludableFile {
  std::string name;  // as shown in #line directives and diagnostics
  std::string text;
  bool once = false;  // #pragma once: served once per stage source
  std::map<std::string, std::string> includes;  // #include name as written -> name of the file it resolved to
};

struct CompileJob {
  uint64_t id = 0;
  JobKind kind = JobKind::Full;
  Stage stage = Stage::Fragment;
  std::string entry_point;
  std::string source_name;
  std::string source;          // preprocessed (Full, FrontEnd)
  std::vector<uint32_t> spirv;  // the front end's module (BackEnd)
  std::vector<Target> targets;
  bool optimize = true;
  bool debug_info = false;  // FrontEnd, Full: the front end writes debug information (BuildOptions::debug_info)
  bool coverage = false;    // BackEnd, Full: coverage probes in the SPIR-V (coverage/instrument.hpp)
  OptimizerRecipe optimizer_recipe = OptimizerRecipe::Kiln;
  BindingOptions bindings;  // FrontEnd, Full: registers -> bindings; BackEnd, Full: combined image samplers
  // Preprocess: the pass's files, the entry first (shared by every job of the pass), and the keywords.
  // FrontEnd and Full with debug_info: the files the source was preprocessed from, the entry first (OpSource).
  std::shared_ptr<const std::vector<IncludableFile>> files;
  std::vector<std::string> defines;  // the pack's "NAME=VALUE" defines, then the stage's keywords
};

// One stage source's preprocessed text: kiln's largest is under 200 KiB; past this a worker stops with an error.
inline constexpr size_t kMaxPreprocessedBytes = size_t{64} << 20;


// FrontEnd: `spirv` is the front end's module. BackEnd and Full: the finished outputs in `blobs`, packed in the
// worker so that each is compressed once, on the core that compiled it.
JobOutput run_compile_job(Frontend& frontend, const CompileJob& job);

std::vector<uint8_t> encode_job(const CompileJob& job);
CompileJob decode_job(const std::vector<uint8_t>& bytes);

}  // namespace kiln
