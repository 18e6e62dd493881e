// SPDX-License-Identifier: Apache-2.0
#include "workers/compile_job.hpp"

#include "coverage/instrument.hpp"
#include "cross/targets.hpp"
#include "frontend/hlsl_compat.hpp"
#include "frontend/interface_semantics.hpp"
#include "frontend/module_limits.hpp"
#include "optimize/spirv_tools.hpp"
#include "reflect/reflect.hpp"

#include "kiln/bounded_json.hpp"

#include <algorithm>
#include <chrono>
#include <set>
#include <stdexcept>

namespace kiln {

using nlohmann::json;

namespace {

// The times of a job's steps, from its arrival in the worker (`kiln build --trace`).
class StepTimes {
 public:
  using Clock = std::chrono::steady_clock;
  // The step that began at `from` ends now; the next begins now.
  Clock::time_point end(CompileStep step, Clock::time_point from) {
    const Clock::time_point now = Clock::now();
    spans_.push_back({step, microseconds(from), static_cast<uint64_t>(
                                                    std::chrono::duration_cast<std::chrono::microseconds>(now - from).count())});
    return now;
  }
  Clock::time_point now() const { return Clock::now(); }
  uint64_t elapsed_us() const { return microseconds(Clock::now()); }
  std::vector<StepSpan> take() { return std::move(spans_); }

 private:
  uint64_t microseconds(Clock::time_point at) const {
    return static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::microseconds>(at - arrived_).count());
  }
  Clock::time_point arrived_ = Clock::now();
  std::vector<StepSpan> spans_;
};

JobOutput compile_front_end(Frontend& frontend, const CompileJob& job) {
  JobOutput out;
  if (job.stage == Stage::Compute) {
    // Thread-group sizes that glslang takes and then mistranslates (0, past 2^31) are the source's error, not a
    // crash of the back end.
    out.messages = check_numthreads_source(job.source, job.source_name, job.entry_point);
  }
  {
    // Arrays of structured and byte-address buffers, which crash glslang 12 or fail its parse (any stage).
    std::vector<FrontendMessage> arrays = check_buffer_arrays_source(job.source, job.source_name);
    out.messages.insert(out.messages.end(), arrays.begin(), arrays.end());
    if (!out.messages.empty()) {
      out.failed_step = CompileStep::Frontend;
      return out;
    }
  }
  std::vector<SourceText> debug_sources;
  if (job.debug_info && job.files)
    for (const IncludableFile& file : *job.files) debug_sources.push_back({file.name, file.text});
  CompileResult compiled = frontend.compile(
      {job.stage, job.entry_point, job.source_name, job.source, job.bindings, job.debug_info, std::move(debug_sources)});
  out.messages = std::move(compiled.messages);
  // A [[vk::...]] attribute glslang ignores where DXC changes the interface: the author's error, never a build with
  // another interface (frontend/hlsl_compat.hpp).
  bool dropped_attribute = false;
  for (FrontendMessage& message : out.messages)
    if (auto error = message.severity == Severity::Warning ? interface_attribute_error(message.text, job.bindings.combines())
                                                           : std::nullopt) {
      message.severity = Severity::Error;
      message.text = std::move(*error);
      dropped_attribute = true;
    }
  if (dropped_attribute) {
    // The error first: the driver reports a stage's first error.
    std::stable_partition(out.messages.begin(), out.messages.end(),
                          [](const FrontendMessage& m) { return m.severity == Severity::Error; });
    out.failed_step = CompileStep::Frontend;
    return out;
  }
  if (compiled.missing_entry_point) {
    out.failed_step = CompileStep::EntryPoint;
  } else if (!compiled.ok) {
    out.failed_step = CompileStep::Frontend;
  } else if (std::vector<FrontendMessage> blocks = check_buffer_blocks(compiled.spirv); !blocks.empty()) {
    out.failed_step = CompileStep::Reflect;  // K1409, located at the block's declaration by its name
    out.messages = std::move(blocks);
  } else if (std::vector<FrontendMessage> limits = job.stage == Stage::Compute
                                                       ? check_compute_module(compiled.spirv, job.source, job.source_name)
                                                       : std::vector<FrontendMessage>{};
             !limits.empty()) {
    out.failed_step = CompileStep::Frontend;
    out.messages.insert(out.messages.end(), limits.begin(), limits.end());
  } else {
    out.ok = true;
    out.spirv = std::move(compiled.spirv);
  }
  return out;
}

JobOutput run_front_end(Frontend& frontend, const CompileJob& job, StepTimes& times) {
  const auto started = times.now();
  JobOutput out = compile_front_end(frontend, job);
  times.end(CompileStep::Frontend, started);
  return out;
}

// Legalize, validate, optimize, validate, reflect, cross-compile: everything after the front end.
JobOutput run_back_end(std::vector<uint32_t> module, const CompileJob& job, StepTimes& times) {
  JobOutput out;
  // The front end's note of each interface variable's HLSL semantic, off the module before anything reads it.
  const InterfaceSemantics semantics = detach_interface_semantics(module);
  auto failed = [&](const SpirvFailure& failure) {
    out.failed_step = failure.step;
    for (const std::string& message : failure.messages) out.messages.push_back({Severity::Error, "", 0, message});
    return out;
  };
  auto step_from = times.now();
  SpirvResult legal = legalize_validate_optimize(std::move(module), job.optimize, job.optimizer_recipe,
                                                 [&] { step_from = times.end(CompileStep::Legalize, step_from); });
  const bool optimized = legal || legal.error().step == CompileStep::Optimize ||
                         legal.error().step == CompileStep::ValidateOptimized;  // else it stopped before -O
  if (job.optimize && optimized) step_from = times.end(CompileStep::Optimize, step_from);
  if (!legal) return failed(legal.error());
  SpirvModule spirv = std::move(*legal);
  out.full_legalization = spirv.full_legalization;
  if (job.bindings.combines()) {
    // A texture and a sampler that share a binding become one combined image sampler (docs/bindings.md).
    SpirvResult combined = combine_image_samplers(spirv.spirv);
    if (!combined) return failed(combined.error());
    spirv.spirv = std::move(combined->spirv);
  }
  if (job.coverage) {
    // Before reflection: the coverage buffer is a resource of the pass like any other, bound by its name.
    Result<InstrumentedModule> instrumented = instrument_coverage(spirv.spirv);
    if (!instrumented) return failed({CompileStep::Instrument, {instrumented.error().message}});
    if (Result<void, SpirvFailure> valid = validate_spirv(instrumented->spirv); !valid)
      return failed({CompileStep::Instrument, valid.error().messages});
    spirv.spirv = std::move(instrumented->spirv);
  }
  step_from = times.now();
  try {
    out.reflection = reflect_spirv(spirv.spirv);
    for (std::vector<StageVariable>* variables : {&out.reflection.inputs, &out.reflection.outputs})
      for (StageVariable& variable : *variables)
        if (auto found = semantics.find(variable.name); found != semantics.end()) variable.semantic = found->second;
  } catch (const ReflectionError& error) {
    out.failed_step = CompileStep::Reflect;
    out.messages.push_back({Severity::Error, "", 0, error.what()});
    return out;
  }
  CrossModules modules(spirv.spirv);
  step_from = times.end(CompileStep::Reflect, step_from);
  for (Target target : job.targets) {
    const TargetBackend* backend = target_backend(target);
    if (!backend) continue;  // SPIR-V: the optimized module itself
    Result<std::string> cross = cross_compile(*backend, modules, out.reflection);
    step_from = times.end(cross_step(backend->target), step_from);
    if (!cross) {
      out.failed_step = cross_step(backend->target);
      out.messages.push_back({Severity::Error, "", 0, cross.error().message});
      out.blobs.clear();
      return out;
    }
    out.blobs[target] = pack_blob(*cross);
  }
  out.blobs[Target::Spirv] = pack_spirv(spirv.spirv);  // whatever the targets: every binary keeps its SPIR-V
  out.ok = true;
  return out;
}

// Serves #include from a Preprocess job's files, by the includes the declaration scan resolved; records
// what was read (the preprocessing memo lists it).
class JobIncludes final : public IncludeSource {
 public:
  explicit JobIncludes(const std::vector<IncludableFile>& files) {
    for (const IncludableFile& file : files) by_name_.emplace(file.name, &file);
  }
  Result<Found> resolve(std::string_view requested, std::string_view from) const override {
    auto including = by_name_.find(std::string(from));
    if (including == by_name_.end()) return failure("unknown including file '" + std::string(from) + "'");
    auto edge = including->second->includes.find(std::string(requested));
    auto target = edge == including->second->includes.end() ? by_name_.end() : by_name_.find(edge->second);
    if (target == by_name_.end())
      return failure("'" + std::string(requested) + "' was not seen by the declaration scan (is the #include name a macro?)");
    read_.insert(target->second->name);
    return Found{target->second->name, target->second->text, target->second->once};
  }
  std::vector<std::string> read() const { return {read_.begin(), read_.end()}; }

 private:
  std::map<std::string, const IncludableFile*> by_name_;
  mutable std::set<std::string> read_;
};

JobOutput run_preprocess(Frontend& frontend, const CompileJob& job, StepTimes& times) {
  JobOutput out;
  const auto started = times.now();
  if (!job.files || job.files->empty()) throw std::runtime_error("a preprocess job without its entry file");
  const IncludableFile& entry = job.files->front();
  JobIncludes includes(*job.files);
  PreprocessResult result = frontend.preprocess({job.stage, entry.name, entry.text, job.defines, &includes});
  times.end(CompileStep::Preprocess, started);
  out.messages = std::move(result.messages);
  if (result.ok && result.text.size() > kMaxPreprocessedBytes) {
    result.ok = false;
    out.messages.push_back({Severity::Error, entry.name, 0,
                            "the preprocessed stage source is " + std::to_string(result.text.size() >> 20) +
                                " MiB, over the limit of " + std::to_string(kMaxPreprocessedBytes >> 20) + " MiB"});
  }
  if (!result.ok) {
    out.failed_step = CompileStep::Preprocess;
    return out;
  }
  out.ok = true;
  out.preprocessed = std::move(result.text);
  out.files_read = includes.read();
  out.files_read.push_back(entry.name);
  return out;
}

}  // namespace

JobOutput run_compile_job(Frontend& frontend, const CompileJob& job) {
  StepTimes times;
  JobOutput out = [&] {
    if (job.kind == JobKind::Preprocess) return run_preprocess(frontend, job, times);
    if (job.kind == JobKind::BackEnd) return run_back_end(job.spirv, job, times);
    JobOutput front = run_front_end(frontend, job, times);
    if (job.kind == JobKind::FrontEnd || !front.ok) return front;
    JobOutput back = run_back_end(std::move(front.spirv), job, times);
    back.messages.insert(back.messages.begin(), front.messages.begin(), front.messages.end());
    return back;
  }();
  out.steps = times.take();
  out.steps_elapsed_us = times.elapsed_us();
  return out;
}

namespace {

json bindings_to_json(const BindingOptions& options) {
  json shifts = json::array();
  for (const auto& [where, shift] : options.shifts)
    shifts.push_back({std::string(1, register_class_letter(where.first)), where.second, shift});
  json j{{"shifts", shifts}};
  if (options.auto_bind) j["auto_bind"] = *options.auto_bind;
  if (options.combined_image_samplers) j["combined"] = *options.combined_image_samplers;
  if (options.global_uniform) j["global"] = {options.global_uniform->first, options.global_uniform->second};
  return j;
}

BindingOptions bindings_from_json(const json& j) {
  BindingOptions options;
  for (const json& shift : j.at("shifts")) {
    auto register_class = parse_register_class(shift.at(0).get<std::string>());
    if (!register_class) throw std::runtime_error("malformed binding shift");
    options.shifts[{*register_class, shift.at(1).get<int64_t>()}] = shift.at(2).get<uint32_t>();
  }
  if (j.contains("auto_bind")) options.auto_bind = j.at("auto_bind").get<bool>();
  if (j.contains("combined")) options.combined_image_samplers = j.at("combined").get<bool>();
  if (j.contains("global")) options.global_uniform = std::make_pair(j.at("global").at(0).get<uint32_t>(), j.at("global").at(1).get<uint32_t>());
  return options;
}

std::vector<uint32_t> binary_to_words(const std::vector<uint8_t>& bytes) {
  return spirv_from_bytes(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

}  // namespace

std::vector<uint8_t> encode_job(const CompileJob& job) {
  json j{{"id", job.id},
         {"kind", static_cast<int>(job.kind)},
         {"stage", stage_name(job.stage)},
         {"entry", job.entry_point},
         {"source_name", job.source_name},
         {"source", job.source},
         {"optimize", job.optimize},
         {"optimizer_recipe", optimizer_recipe_name(job.optimizer_recipe)},
         {"bindings", bindings_to_json(job.bindings)}};
  json targets = json::array();
  for (Target t : job.targets) targets.push_back(target_name(t));
  j["targets"] = targets;
  if (!job.spirv.empty()) j["spirv"] = json::binary(spirv_to_bytes(job.spirv));
  if (job.debug_info) j["debug_info"] = true;
  if (job.coverage) j["coverage"] = true;
  if (job.kind == JobKind::Preprocess) j["defines"] = job.defines;
  if (job.kind == JobKind::Preprocess || (job.debug_info && job.files)) {
    json files = json::array();
    if (job.files)
      for (const IncludableFile& f : *job.files) files.push_back({f.name, f.text, f.once, f.includes});
    j["files"] = std::move(files);
  }
  return json::to_cbor(j);
}

CompileJob decode_job(const std::vector<uint8_t>& bytes) {
  json j = decode_cbor_bounded(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()),
                               {bytes.size(), kMaxJsonDepth});
  CompileJob job;
  job.id = j.at("id").get<uint64_t>();
  int kind = j.at("kind").get<int>();
  if (kind < 0 || kind > static_cast<int>(JobKind::Preprocess)) throw std::runtime_error("unknown job kind");
  job.kind = static_cast<JobKind>(kind);
  if (j.contains("spirv")) job.spirv = binary_to_words(j.at("spirv").get_binary());
  job.stage = parse_stage(j.at("stage").get<std::string>()).value_or(Stage::Fragment);
  job.entry_point = j.at("entry").get<std::string>();
  job.source_name = j.at("source_name").get<std::string>();
  job.source = j.at("source").get<std::string>();
  job.optimize = j.at("optimize").get<bool>();
  job.debug_info = j.contains("debug_info") && j.at("debug_info").get<bool>();
  job.coverage = j.contains("coverage") && j.at("coverage").get<bool>();
  job.optimizer_recipe =
      parse_optimizer_recipe(j.at("optimizer_recipe").get<std::string>()).value_or(OptimizerRecipe::Kiln);
  job.bindings = bindings_from_json(j.at("bindings"));
  for (const json& t : j.at("targets"))
    if (auto target = parse_target(t.get<std::string>())) job.targets.push_back(*target);
  if (job.kind == JobKind::Preprocess) job.defines = j.at("defines").get<std::vector<std::string>>();
  if (job.kind == JobKind::Preprocess || j.contains("files")) {
    auto files = std::make_shared<std::vector<IncludableFile>>();
    for (const json& f : j.at("files"))
      files->push_back({f.at(0).get<std::string>(), f.at(1).get<std::string>(), f.at(2).get<bool>(),
                        f.at(3).get<std::map<std::string, std::string>>()});
    job.files = std::move(files);
  }
  return job;
}

}  // namespace kiln
