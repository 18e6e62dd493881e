// SPDX-License-Identifier: Apache-2.0
// What a compile job gives back, and its one encoding: the worker pipe carries it, and the cache stores it (so a
// worker's output and a cached result are the same record).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/blob.hpp"
#include "common/compile_step.hpp"
#include "kiln/diagnostics.hpp"
#include "kiln/manifest_json.hpp"
#include "kiln/model.hpp"

namespace kiln {

// One message of the front end, in the user's file coordinates (via #line).
struct FrontendMessage {
  Severity severity = Severity::Error;
  std::string path;
  int line = 0;
  std::string text;
  int column = 0;  // when the front end says (glslang's HLSL parser does for "HLSL parsing failed")
  // A column glslang counted in the preprocessed text (not the file's spacing) names its token instead, and which
  // of the line's tokens of that text it is (1-based): the driver finds the same one in the file's line.
  std::string token;
  int occurrence = 0;
};

// How long one step of a job took in the worker, counted from the job's arrival there (`kiln build --trace`). Only
// the worker pipe carries them: the pool moves them off the output, so no cache entry ever holds a time.
struct StepSpan {
  CompileStep step = CompileStep::None;  // Preprocess, Frontend, Legalize, Optimize, Reflect or Cross<Target>
  uint64_t start_us = 0;
  uint64_t duration_us = 0;
};
// A job has at most a dozen steps; a worker's answer with more, or with steps out of order, is malformed.
inline constexpr size_t kMaxStepSpans = 64;

struct JobOutput {
  bool ok = false;
  CompileStep failed_step = CompileStep::None;  // where it failed (common/compile_step.hpp)
  std::vector<FrontendMessage> messages;
  std::vector<uint32_t> spirv;            // FrontEnd: the front end's module (not legal SPIR-V yet)
  std::map<Target, PackedBlob> blobs;     // BackEnd, Full: every output, the optimized SPIR-V included
  Reflection reflection;                   // BackEnd, Full: reflect_spirv + each target's binding records
  bool full_legalization = false;          // legalized by SPIRV-Tools' full recipe (the core one was not enough)
  std::string preprocessed;                // Preprocess: the text
  std::vector<std::string> files_read;     // Preprocess: the names of the files it read, the entry included
  std::vector<StepSpan> steps;             // in the worker only, in order: encoded only `with_steps`
  uint64_t steps_elapsed_us = 0;           // with `steps`: from the job's arrival in the worker to its end there
};

// `with_steps`: the worker's answer (its step times); a cache entry never has them.
std::vector<uint8_t> encode_output(const JobOutput& output, bool with_steps = false);
JobOutput decode_output(const std::vector<uint8_t>& bytes);  // throws on malformed input
JobOutput decode_output(std::string_view bytes);

}  // namespace kiln
