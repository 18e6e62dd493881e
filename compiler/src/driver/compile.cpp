// SPDX-License-Identifier: Apache-2.0
#include "common/target_environment.hpp"
#include "driver/compile.hpp"

#include <algorithm>
#include <map>
#include <set>

#include "common/files.hpp"
#include "common/parallel.hpp"
#include "driver/build_context.hpp"
#include "driver/build_trace.hpp"
#include "frontend/unsupported_hlsl.hpp"
#include "kiln/folded_keywords.hpp"

namespace kiln {
namespace {

// The diagnostic a failed compile step is reported with: the one place steps meet diagnostic IDs.
DiagId diagnostic_for(CompileStep step) {
  switch (step) {
    case CompileStep::Frontend: return DiagId::HlslError;
    case CompileStep::EntryPoint: return DiagId::MissingEntryPoint;
    case CompileStep::Preprocess: return DiagId::PreprocessorError;
    case CompileStep::Legalize:
    case CompileStep::CombineImageSamplers:
    case CompileStep::Optimize: return DiagId::OptimizerFailed;
    case CompileStep::Validate:
    case CompileStep::ValidateOptimized: return DiagId::SpirvInvalid;
    case CompileStep::Reflect: return DiagId::BlockTooLarge;
    case CompileStep::Instrument: return DiagId::CoverageUnavailable;
#define KILN_CROSS_TARGET(Enumerator, ...) case CompileStep::Cross##Enumerator:
#include "kiln/targets.def"
      return DiagId::CrossCompileFailed;
    case CompileStep::None:
    case CompileStep::OutOfMemory:  // the pool reports these as outcomes, not as failed steps
    case CompileStep::Internal: break;
  }
  return DiagId::InternalCompilerError;
}

// One compile of a build's stage sources, streamed from their preprocessing: one front end per distinct source
// key, one back end per distinct module, and each binary settled from its key's result after the stream.
class Scheduler {
 public:
  Scheduler(BuildContext& build, const Plan& plan, const BuildSettings& settings, Shard shard, StageSources& sources,
            CompileServices services, const SourceLocator& locator, MessageGroups& messages)
      : build_(build), plan_(plan), settings_(settings), shard_(shard), sources_(sources), services_(services),
        locator_(locator), messages_(messages), sink_(build.sink), binaries_(results_.binaries),
        counts_(results_.counts) {}

  CompileResults run() {
    const auto compile_from = StageClock::now();
    // A shard takes its share of the stage sources before anything is preprocessed: the others are not its work.
    if (shard_.count > 1) {
      const std::vector<uint32_t> shares = source_shares(sources_, shard_.count);
      for (size_t i = 0; i < sources_.list.size(); ++i)
        if (shares[i] != shard_.index) {
          sources_.list[i].elsewhere = true;
          ++counts_.shard_skipped;
        }
    }
    for (size_t i = 0; i < sources_.list.size(); ++i)
      if (!sources_.list[i].elsewhere) enter(i);
    progress();
    stream();
    build_.record_stage("preprocess", sources_.enumerated_from, last_preprocessed_.value_or(compile_from));
    binaries_ = dedupe_stage_sources(build_, sources_, plan_, locator_, messages_);  // in source order
    total_known_ = true;
    // Every question to the store answered (its problems said before any compile message), and the answers it held
    // until now taken.
    answered(services_.store.finish(sink_));
    if (!results_.cancelled) stream();
    settle_binaries();
    counts_.compiled = front_ends_;
    build_.record_stage("compile", first_front_end_.value_or(compile_from), StageClock::now());
    return std::move(results_);
  }

 private:
  // What became of one distinct source key: found whole (in the store) or compiled.
  struct KeyResult {
    size_t source = 0;                         // the stage source whose text its front end compiles
    bool started = false;                      // its front end is queued, or it waits for the store's answer
    std::shared_ptr<const JobOutput> output;   // found whole
    std::optional<Hash128> module;             // its module: from the front end, or the store's
    bool front_end_ran = false;
    std::optional<WorkerOutcome> front_end_failure;
    std::vector<FrontendMessage> front_messages;
  };

  // A stage source enters the stream: preprocessed already, known through a memo, or to be preprocessed.
  void enter(size_t i) {
    StageSource& s = sources_.list[i];
    if (s.preprocessed) {
      if (s.ok) preprocessed(i);
      return;
    }
    // A memo gives the key without the text: the store may have the result; if not, the workers need the text.
    if (s.key && results_by_key_[result_for(*s.key, i)].output) return;
    jobs_.push_back(services_.preprocessor.job(sources_, i));
    job_subject_.push_back(i);
    ++unpreprocessed_;
  }

  // The result of `key` (its index), looked up in the store the first time the key is seen.
  size_t result_for(const Hash128& key, size_t source) {
    auto [it, inserted] = result_by_key_.emplace(key, results_by_key_.size());
    if (!inserted) return it->second;
    KeyResult& result = results_by_key_.emplace_back();
    result.source = source;
    const StageClock::time_point looked_from = StageClock::now();
    std::optional<StoredResult> found = services_.store.find(key);
    trace_lookup("cache lookups", "cache lookup", looked_from, found.has_value(), source);
    if (found) {
      result.output = std::move(found->output);
      result.module = found->module;
      ++counts_.cache_hits;
      ++done_;
    }
    return it->second;
  }

  // Source `i` has its text: its key's front end is queued unless an earlier source of that key queued it (a
  // duplicate arriving late is never compiled twice) or the store has its result.
  void preprocessed(size_t i) {
    const size_t index = result_for(*sources_.list[i].key, i);
    KeyResult& result = results_by_key_[index];
    if (result.output || result.started) return;
    result.started = true;
    result.source = i;
    if (!services_.store.ask(index, sources_.list[i])) queue_front_end(index);
    else if (build_.trace) asked_at_.emplace(index, StageClock::now());
  }

  // The store's answers so far: a found result settles its key, a miss queues its front end.
  void answered(std::vector<ResultStore::Answer> answers) {
    for (ResultStore::Answer& answer : answers) {
      if (auto asked = asked_at_.find(answer.ticket); asked != asked_at_.end()) {
        trace_lookup("remote lookups", "remote lookup", asked->second, answer.found.has_value(),
                     results_by_key_[answer.ticket].source);
        asked_at_.erase(asked);
      }
      if (!answer.found) {
        queue_front_end(answer.ticket);
        continue;
      }
      KeyResult& result = results_by_key_[answer.ticket];
      result.output = std::move(answer.found->output);
      result.module = answer.found->module;
      ++done_;
    }
    progress();
  }

  void queue_front_end(size_t index) {
    KeyResult& result = results_by_key_[index];
    const StageSource& s = sources_.list[result.source];
    if (!first_front_end_) first_front_end_ = StageClock::now();
    CompileJob job;
    job.id = index;
    job.kind = JobKind::FrontEnd;
    job.stage = s.stage;
    job.entry_point = plan_.entry_point(s.pass, s.stage);
    job.source_name = display_path(plan_.declarations[s.pass].stage_entry[static_cast<size_t>(s.stage)]);
    job.source = s.text;
    job.targets = settings_.targets_for(plan_.pack.passes[s.pass]);
    job.optimize = settings_.optimize;
    job.debug_info = settings_.debug_info;
    if (job.debug_info) job.files = s.debug_files;  // the original files, for OpSource
    job.coverage = settings_.coverage;
    job.optimizer_recipe = settings_.optimizer_recipe;
    job.bindings = plan_.pack.passes[s.pass].bindings_for(s.stage);
    jobs_.push_back(std::move(job));
    job_subject_.push_back(index);
    ++front_ends_;
  }

  // Runs the queued jobs; finished jobs queue their follow-ups (a preprocessed source's front end, a new
  // module's back end), which the runner sends next.
  void stream() {
    if (jobs_.empty() && services_.store.outstanding() == 0) return;
    std::vector<CompileJob> jobs = std::move(jobs_);
    std::vector<size_t> subjects = std::move(job_subject_);
    jobs_.clear();
    job_subject_.clear();
    running_ = &jobs;
    running_subjects_ = &subjects;
    // Follow-ups queued by an outcome or a store's answer join the running stream.
    auto join_queued = [&] {
      for (size_t q = 0; q < jobs_.size(); ++q) {
        jobs.push_back(std::move(jobs_[q]));
        subjects.push_back(job_subject_[q]);
      }
      jobs_.clear();
      job_subject_.clear();
    };
    // The store's later answers arrive while the workers run.
    ExternalWork answers;
    answers.fd = services_.store.ready_fd();
    answers.pending = [&] { return services_.store.outstanding() > 0; };
    answers.arrived = [&] {
      answered(services_.store.answers());
      join_queued();
    };
    services_.runner.run(jobs, [&](size_t j, WorkerOutcome outcome) {
      if (build_.trace && outcome.timing) trace_job(jobs[j], subjects[j], *outcome.timing);
      switch (jobs[j].kind) {
        case JobKind::Preprocess: preprocess_done(j, std::move(outcome)); break;
        case JobKind::FrontEnd: front_end_done(j, std::move(outcome)); break;
        case JobKind::BackEnd:
        case JobKind::Full: back_end_done(j, std::move(outcome)); break;
      }
      join_queued();
      progress();
    }, answers.fd >= 0 ? &answers : nullptr);
    running_ = nullptr;
    running_subjects_ = nullptr;
  }

  // A job the runner did not run: the build was interrupted.
  bool cancelled(const WorkerOutcome& outcome) {
    if (outcome.kind != WorkerOutcome::Kind::Cancelled) return false;
    results_.cancelled = true;
    return true;
  }

  void preprocess_done(size_t j, WorkerOutcome outcome) {
    const size_t i = (*running_subjects_)[j];
    if (cancelled(outcome)) {  // not preprocessed: no binary, no message (as another shard's source)
      sources_.list[i].elsewhere = true;
      --unpreprocessed_;
      return;
    }
    services_.preprocessor.finished(sources_.list[i], std::move(outcome));
    std::vector<std::string>().swap((*running_)[j].defines);
    --unpreprocessed_;
    if (sources_.list[i].ok) preprocessed(i);
    last_preprocessed_ = StageClock::now();  // after its front end is queued: the stages' overlap shows in order
  }

  // A finished job's input (its source text or its module) is not read again: free it now, not when the build
  // ends (`= {}` would keep the capacity).
  void release_input(size_t j) {
    std::string().swap((*running_)[j].source);
    std::vector<uint32_t>().swap((*running_)[j].spirv);
  }

  void back_end_done(size_t j, WorkerOutcome outcome) {
    CompiledModule& module = results_.modules[(*running_subjects_)[j]];
    if (cancelled(outcome)) return;  // unsettled: its binaries get no output and no message
    module.settled = true;
    module.fresh = outcome.kind == WorkerOutcome::Kind::Done && outcome.output.ok;
    if (module.fresh) {
      if (outcome.output.full_legalization) ++counts_.full_legalizations;
      module.output = std::make_shared<const JobOutput>(std::move(outcome.output));
      release_input(j);
    } else {
      module.failure = std::move(outcome);
      module.failed_input = std::move((*running_)[j].spirv);  // for the reproducer of each binary of the module
    }
    done_ += module.waiting.size();
    module.waiting = {};
  }

  void front_end_done(size_t j, WorkerOutcome outcome) {
    CompileJob& job = (*running_)[j];
    std::string().swap(job.source);
    const size_t index = (*running_subjects_)[j];
    KeyResult& result = results_by_key_[index];
    if (cancelled(outcome)) return;  // its binaries get no output and no message
    result.front_end_ran = true;
    if (outcome.kind != WorkerOutcome::Kind::Done || !outcome.output.ok) {
      result.front_end_failure = std::move(outcome);
      ++done_;
      return;
    }
    const StageSource& s = sources_.list[result.source];
    result.front_messages = std::move(outcome.output.messages);
    const std::vector<uint32_t>& spirv = outcome.output.spirv;
    Hasher module_key;
    Hash128 key = settings_.add_compile_options(module_key, plan_.pack.passes[s.pass], s.stage)
                      .add(std::string_view(reinterpret_cast<const char*>(spirv.data()), spirv.size() * 4))
                      .finish();
    result.module = key;
    auto [it, inserted] = module_by_key_.emplace(key, results_.modules.size());
    if (inserted) {
      CompiledModule module;
      module.key = key;
      const StageClock::time_point looked_from = StageClock::now();
      std::optional<JobOutput> found = services_.store.find_module(key, s, spirv);
      trace_lookup("cache lookups", "cache lookup (module)", looked_from, found.has_value(), result.source);
      if (found) {
        module.settled = true;
        module.output = std::make_shared<const JobOutput>(std::move(*found));
        ++counts_.back_end_hits;
      }
      if (!module.settled) {
        CompileJob back;
        back.id = results_.modules.size();
        back.kind = JobKind::BackEnd;
        back.stage = job.stage;
        back.entry_point = job.entry_point;
        back.source_name = job.source_name;
        back.spirv = std::move(outcome.output.spirv);  // `spirv` is not read again on this path
        back.targets = job.targets;
        back.optimize = job.optimize;
        back.debug_info = job.debug_info;
        back.coverage = job.coverage;
        back.optimizer_recipe = job.optimizer_recipe;
        back.bindings = job.bindings;
        jobs_.push_back(std::move(back));  // runs next, in whichever worker is free
        job_subject_.push_back(results_.modules.size());
        ++counts_.back_ends;
      }
      results_.modules.push_back(std::move(module));
    }
    CompiledModule& module = results_.modules[it->second];
    if (module.settled) ++done_;
    else module.waiting.push_back(index);
  }

  // The trace's words for a stage source: its pass, stage and the keywords it sees (not the folded keywords' macros).
  nlohmann::json trace_args(size_t source) const {
    const StageSource& s = sources_.list[source];
    std::vector<std::string> keywords;
    for (const std::string& k : s.defines)
      if (k.find('=') == std::string::npos && !k.starts_with("KILN_FOLDED_")) keywords.push_back(k);
    return {{"pass", plan_.pack.passes[s.pass].name}, {"stage", stage_name(s.stage)}, {"keywords", keywords}};
  }

  void trace_lookup(const char* kind, const char* name, StageClock::time_point from, bool found, size_t source) {
    if (!build_.trace) return;
    nlohmann::json args = trace_args(source);
    args["found"] = found;
    build_.trace->driver_slice(kind, name, from, StageClock::now(), std::move(args));
  }

  // A job a worker ran, in the trace: which half of which stage source (a back end: of the first source whose front
  // end made its module).
  void trace_job(const CompileJob& job, size_t subject, const JobTiming& timing) {
    std::optional<size_t> source;
    const char* what = "compile";
    switch (job.kind) {
      case JobKind::Preprocess: what = "preprocess"; source = subject; break;
      case JobKind::FrontEnd: what = "front end"; source = results_by_key_[subject].source; break;
      case JobKind::BackEnd:
      case JobKind::Full:
        what = job.kind == JobKind::BackEnd ? "back end" : "compile";
        if (const CompiledModule& module = results_.modules[subject]; !module.waiting.empty())
          source = results_by_key_[module.waiting.front()].source;
        break;
    }
    nlohmann::json args = source ? trace_args(*source) : nlohmann::json::object();
    args["job"] = what;
    std::string name = what;
    if (source) name += ": " + variant_description(plan_, sources_.list[*source]);
    build_.trace->worker_job(timing, std::move(name), std::move(args));
  }

  // Stage sources done out of those there will be: until every source is preprocessed, the keys known so far plus
  // the sources still to preprocess (duplicates among them make it shrink).
  void progress() {
    const size_t total = total_known_ ? binaries_.size() : results_by_key_.size() + unpreprocessed_;
    build_.report_progress(done_, total, counts_.cache_hits);
  }

  // Every binary, in order, takes its key's result: its module's output, or its diagnostics.
  void settle_binaries() {
    results_.module_of.resize(binaries_.size());
    results_.front_messages.resize(binaries_.size());
    results_.front_end_ran.assign(binaries_.size(), false);
    std::set<Hash128> distinct_modules;  // among the built binaries, compiled now or found in the store
    for (size_t b = 0; b < binaries_.size(); ++b) {
      KeyResult& result = results_by_key_[result_by_key_.at(binaries_[b].key)];
      results_.module_of[b] = result.module;
      if (result.output) {
        binaries_[b].output = result.output;
      } else if (result.front_end_ran) {
        results_.front_end_ran[b] = true;
        settle(b, result);
      }
      if (binaries_[b].output) distinct_modules.insert(results_.module_of[b].value_or(binaries_[b].key));
    }
    results_.unique_modules = distinct_modules.size();
    progress();
  }

  void settle(size_t b, KeyResult& result) {
    if (result.front_end_failure) {
      fail(b, *result.front_end_failure, nullptr);
      return;
    }
    const StageSource& s = sources_.list[binaries_[b].source];
    for (const FrontendMessage& m : result.front_messages)
      if (m.severity == Severity::Warning)
        messages_.collect(DiagId::HlslWarning, locator_.located(m, ""), m.text, variant_description(plan_, s),
                          sources_.list.size() + b);
    results_.front_messages[b] = result.front_messages;
    const CompiledModule& module = results_.modules[module_by_key_.at(*result.module)];
    if (module.output) binaries_[b].output = module.output;
    else if (module.settled) fail(b, module.failure, &module.failed_input);  // unsettled: its back end was cancelled
  }

  // `module`: the front end's SPIR-V, when the worker died in the back end.
  void fail(size_t b, const WorkerOutcome& outcome, const std::vector<uint32_t>* module) {
    const Binary& binary = binaries_[b];
    const StageSource& s = sources_.list[binary.source];
    const std::string variant = variant_description(plan_, s);
    const size_t order = sources_.list.size() + b;
    const DiagId id = diagnostic_for(outcome.output.failed_step);
    // A crash, or a step no diagnostic is for (an exception inside the worker), is kiln's bug: exit 2, never a
    // user error.
    const bool threw = outcome.kind == WorkerOutcome::Kind::Done && id == DiagId::InternalCompilerError;
    if (outcome.kind != WorkerOutcome::Kind::Done || threw) {
      const std::string what = outcome.output.failed_step == CompileStep::Internal
                                   ? std::string("threw an exception (")
                                   : "failed in step '" + std::string(step_name(outcome.output.failed_step)) + "' (";
      const std::string detail =
          threw ? what + (outcome.output.messages.empty() ? std::string("no message") : outcome.output.messages[0].text) + ")"
                : outcome.detail;
      internal_compiler_error(binary, s, variant, detail, module);
      return;
    }
    const std::string entry_name = display_path(plan_.declarations[s.pass].stage_entry[static_cast<size_t>(s.stage)]);
    const std::string step(step_name(outcome.output.failed_step));
    if (id == DiagId::MissingEntryPoint) {
      SourceLocation at = locate_json_string(plan_.pack.file.string(), plan_.pack.text, binary.entry_point);
      messages_.collect(DiagId::MissingEntryPoint, at,
                        "entry point '" + binary.entry_point + "' of the " + std::string(stage_name(s.stage)) +
                            " stage is not defined in '" + entry_name + "'",
                        variant, order);
      return;
    }
    // Only the first error: glslang's later ones cascade from it ("'declaration' : Expected").
    auto first = std::find_if(outcome.output.messages.begin(), outcome.output.messages.end(),
                              [](const FrontendMessage& m) { return m.severity == Severity::Error; });
    if (first != outcome.output.messages.end() && id == DiagId::BlockTooLarge) {
      messages_.collect(id, locator_.declaration(s.pass, quoted_name(first->text), entry_name), first->text, variant, order);
    } else if (first != outcome.output.messages.end() && outcome.output.failed_step == CompileStep::CombineImageSamplers) {
      // kiln's texture-array combining names the resource it cannot combine ('s' : ...): at its declaration.
      messages_.collect(id, locator_.declaration(s.pass, quoted_name(first->text), entry_name), step + ": " + first->text,
                        variant, order);
    } else if (first != outcome.output.messages.end()) {
      if (id == DiagId::HlslError && constant_id_collision(*first, s, variant, order)) return;
      SourceLocation at = locator_.located(*first, entry_name);
      if (id == DiagId::HlslError) {
        if (auto unsupported = recognise_unsupported_hlsl(first->text, locator_.line(at.path, at.line))) {
          if (unsupported->column) at.column = unsupported->column;
          messages_.collect(id, at,
                            "glslang 12's HLSL front end does not support " + unsupported->construct + " (it said: " +
                                first->text + ")",
                            variant, order, {unsupported->advice + " (docs/bindings.md lists what glslang 12 does not take)"});
          return;
        }
      }
      std::string prefix = id == DiagId::HlslError ? "" : step + ": ";
      messages_.collect(id, at, prefix + first->text, variant, order);
    } else {
      messages_.collect(id, SourceLocation{entry_name, 0, 0}, step + " failed", variant, order);
    }
  }

  // glslang says a specialization constant id is used twice without saying where: when the shader's own
  // `vk::constant_id` takes an id kiln gives a folded keyword of this stage (kiln/folded_keywords.hpp), the error is
  // at the shader's number, naming the keyword.
  bool constant_id_collision(const FrontendMessage& message, const StageSource& s, const std::string& variant, size_t order) {
    if (message.text.find("specialization-constant id already used") == std::string::npos) return false;
    std::map<uint32_t, std::string> keyword_of;
    for (const FoldedKeyword& k : folded_keywords(plan_.keyword_group_records(s.pass)))
      if (is_constant(k.kind) && (k.stages & stage_bit(s.stage)) && !k.keyword.empty()) keyword_of.emplace(k.slot, k.keyword);
    std::set<uint32_t> ids;
    for (const auto& [id, keyword] : keyword_of) ids.insert(id);
    const auto found = locator_.constant_id(s.pass, ids);
    if (!found) return false;
    messages_.collect(DiagId::HlslError, found->first,
                      "specialization constant id " + std::to_string(found->second) +
                          " is the one kiln gives folded keyword '" + keyword_of.at(found->second) + "'",
                      variant, order,
                      {"kiln numbers a pass's specialization_constant keywords (and specialization_constant_int groups) from " +
                       std::to_string(kKeywordConstantIdBase) + " (docs/keywords.md): give the shader's own constants ids below it"});
    return true;
  }

  // A reproducer next to the outputs: the exact preprocessed source the worker was given, and for a back-end
  // death the module it was given too, with the SPIRV-Tools commands that replay the back end.
  void internal_compiler_error(const Binary& binary, const StageSource& s, const std::string& variant,
                               const std::string& detail, const std::vector<uint32_t>* module) {
    const std::filesystem::path& dir = build_.reproducers;
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    const std::string base = plan_.pack.passes[s.pass].name + "." + std::string(stage_name(s.stage)) + "." + keywords_slug(s.defines);
    std::filesystem::path repro = dir / (base + ".hlsl");
    std::string header = "// kiln internal compiler error: the compiler worker " + detail + "\n// " + variant +
                         ", entry point " + binary.entry_point + "\n// reproduce: glslangValidator -D -V -S " +
                         std::string(stage_short_name(s.stage)) + " -e " + binary.entry_point + " " +
                         repro.filename().string() + "\n";
    std::vector<std::string> notes;
    std::vector<std::string> unwritten;  // a reproducer that could not be written is said, not dropped
    if (module) {
      std::filesystem::path spv = dir / (base + ".spv");
      Result<void> written =
          write_output_file(spv, std::string_view(reinterpret_cast<const char*>(module->data()), module->size() * 4));
      header += "// the front end succeeded; the worker died in the back end, given " + spv.filename().string() +
                ":\n// spirv-opt --legalize-hlsl " + base + ".spv -o legal.spv && spirv-val --target-env " + kTargetEnvironment.spirv_env +
                " legal.spv && spirv-opt -O legal.spv -o opt.spv && spirv-cross opt.spv\n";
      if (written) notes.push_back("the front end's SPIR-V module (the back end's input) written to " + spv.string());
      else unwritten.push_back("the front end's SPIR-V module could not be written: " + written.error().message);
    }
    if (Result<void> written = write_output_file(repro, header + s.text))
      notes.insert(notes.begin(), "reproducer written to " + repro.string());
    else
      unwritten.insert(unwritten.begin(), "the reproducer could not be written: " + written.error().message);
    notes.insert(notes.end(), unwritten.begin(), unwritten.end());
    notes.push_back("this is a bug in the compiler, not in your shader");
    sink_.report(DiagId::InternalCompilerError, SourceLocation{display_path(plan_.declarations[s.pass].stage_entry[static_cast<size_t>(s.stage)]), 0, 0},
                 "internal compiler error: the compiler worker " + detail + " while compiling " + variant, notes);
  }

  BuildContext& build_;
  const Plan& plan_;
  const BuildSettings& settings_;
  Shard shard_;
  StageSources& sources_;
  CompileServices services_;
  const SourceLocator& locator_;
  MessageGroups& messages_;
  DiagnosticSink& sink_;

  CompileResults results_;
  std::vector<Binary>& binaries_;  // results_'s
  CompileCounts& counts_;          // results_'s
  std::vector<KeyResult> results_by_key_;
  std::map<Hash128, size_t> result_by_key_;   // source key -> its index in results_by_key_
  std::map<Hash128, size_t> module_by_key_;
  std::vector<CompileJob> jobs_;             // queued, not yet handed to the runner
  std::vector<size_t> job_subject_;          // Preprocess job -> source, FrontEnd -> key result, BackEnd -> module
  std::vector<CompileJob>* running_ = nullptr;  // the runner's jobs, while it runs
  std::vector<size_t>* running_subjects_ = nullptr;
  size_t unpreprocessed_ = 0;
  size_t front_ends_ = 0;
  size_t done_ = 0;
  bool total_known_ = false;
  std::optional<StageClock::time_point> last_preprocessed_;
  std::optional<StageClock::time_point> first_front_end_;  // the compile stage starts here
  std::map<size_t, StageClock::time_point> asked_at_;       // --trace: key results asked of the slower tiers, when
};

}  // namespace

CompileResults compile_stage_sources(BuildContext& build, const Plan& plan, const BuildSettings& settings, Shard shard,
                                     StageSources& sources, CompileServices services, const SourceLocator& locator,
                                     MessageGroups& messages) {
  return Scheduler(build, plan, settings, shard, sources, services, locator, messages).run();
}

}  // namespace kiln
