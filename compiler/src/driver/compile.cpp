#include "common/target_environment.hpp"
#include "driver/compile.hpp"

#include <algorithm>
#include <set>

#include "common/files.hpp"
#include "common/parallel.hpp"
#include "driver/remote.hpp"
#include "driver/stage_timer.hpp"

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
    case CompileStep::CrossGlsl:
    case CompileStep::CrossGles:
    case CompileStep::CrossMsl: return DiagId::CrossCompileFailed;
    case CompileStep::None:
    case CompileStep::OutOfMemory:  // the pool reports these as outcomes, not as failed steps
    case CompileStep::Internal: break;
  }
  return DiagId::InternalCompilerError;
}

// One compile: front ends for the misses, back ends as their modules appear, each binary settled exactly once.
class Scheduler {
 public:
  Scheduler(const Plan& plan, const BuildOptions& options, const BuildSettings& settings, StageSources& sources,
            std::vector<Binary>& binaries, CompileServices services, const SourceLocator& locator, MessageGroups& messages,
            DiagnosticSink& sink, BuildReport& report)
      : plan_(plan), options_(options), settings_(settings), sources_(sources), binaries_(binaries), services_(services),
        locator_(locator), messages_(messages), sink_(sink), report_(report) {
    results_.module_of.resize(binaries.size());
    results_.front_messages.resize(binaries.size());
    results_.front_end_ran.assign(binaries.size(), false);
    results_.remote_key_of.resize(binaries.size());
  }

  CompileResults run() {
    std::vector<size_t> misses = load_cached();
    queue_front_ends(misses);
    report_.compiled = jobs_.size();
    done_ = report_.cache_hits + remote_hits_;
    if (options_.progress) options_.progress(done_, binaries_.size(), report_.cache_hits);
    if (!jobs_.empty()) {
      services_.runner.run(jobs_, [&](size_t j, WorkerOutcome outcome) {
        if (jobs_[j].kind == JobKind::BackEnd) back_end_done(j, std::move(outcome));
        else front_end_done(j, std::move(outcome));
      });
      report_.workers_started = services_.runner.spawned();
    }
    // Distinct modules among the built binaries, whether compiled now or found through cache aliases.
    std::set<Hash128> distinct_modules;
    for (size_t b = 0; b < binaries_.size(); ++b)
      if (binaries_[b].output) distinct_modules.insert(results_.module_of[b].value_or(binaries_[b].key));
    report_.funnel.unique_modules = distinct_modules.size();
    return std::move(results_);
  }

 private:
  // The binaries the cache has whole (through their source key's alias); the others are misses.
  std::vector<size_t> load_cached() {
    std::vector<size_t> misses;
    for (size_t b = 0; b < binaries_.size(); ++b) {
      if (services_.cache) {
        bool rejected = false;
        if (auto cached = services_.cache->load(binaries_[b].key, rejected, &results_.module_of[b]))
          binaries_[b].output = std::make_shared<const JobOutput>(std::move(*cached));
        if (rejected) ++report_.cache_rejected;
        if (binaries_[b].output) {
          ++report_.cache_hits;
          continue;
        }
      }
      misses.push_back(b);
    }
    return misses;
  }

  void queue_front_ends(const std::vector<size_t>& misses) {
    // Misses known only through a memo are preprocessed now: the workers need their text.
    std::vector<size_t> unpreprocessed;
    for (size_t b : misses)
      if (!sources_.list[binaries_[b].source].preprocessed) unpreprocessed.push_back(binaries_[b].source);
    services_.preprocessor.run(sources_, unpreprocessed);
    fetch_from_remote(misses);
    for (size_t b : misses) {
      if (binaries_[b].output) continue;  // from the remote cache
      const StageSource& s = sources_.list[binaries_[b].source];
      if (!s.ok) {  // the memo said it preprocessed; it does not now (it cannot, with the same files)
        report_preprocess_failure(s, binaries_[b].source, plan_, locator_, messages_, sink_, report_);
        continue;
      }
      if (options_.shard_count > 1 && s.key->low % options_.shard_count != options_.shard_index) {
        ++report_.shard_skipped;  // another shard's
        continue;
      }
      binaries_[b].key = *s.key;  // the text's own key, whatever a memo said
      CompileJob job;
      job.id = b;
      job.kind = JobKind::FrontEnd;
      job.stage = binaries_[b].stage;
      job.entry_point = binaries_[b].entry_point;
      job.source_name = display_path(plan_.declarations[s.pass].entry);
      job.source = s.text;
      job.targets = settings_.targets;
      job.optimize = settings_.optimize;
      job.optimizer_recipe = settings_.optimizer_recipe;
      job.bindings = plan_.pack.passes[s.pass].bindings;
      jobs_.push_back(std::move(job));
      job_subject_.push_back(b);
    }
  }

  // The misses the remote has: not compiled. Their entries, verified by the remote tier, go into the local cache.
  void fetch_from_remote(const std::vector<size_t>& misses) {
    RemoteCache* remote = services_.remote;
    if (!remote || !remote->usable()) return;
    std::vector<size_t> asked;
    std::vector<RemoteKey> keys;
    for (size_t b : misses) {
      const StageSource& s = sources_.list[binaries_[b].source];
      if (!s.ok) continue;
      results_.remote_key_of[b] = remote_source_key(*remote, settings_, plan_.pack.passes[s.pass], s.stage, s.text);
      asked.push_back(b);
      keys.push_back(*results_.remote_key_of[b]);
    }
    std::vector<std::optional<RemoteFetched>> fetched = remote->fetch(keys);
    for (size_t i = 0; i < asked.size(); ++i) {
      if (!fetched[i]) continue;
      const size_t b = asked[i];
      RemoteFetched& hit = *fetched[i];
      if (services_.cache) {
        services_.cache->store(hit.module, hit.module_output);
        services_.cache->store_alias(*sources_.list[binaries_[b].source].key, hit.module, hit.front_messages);
      }
      hit.module_output.messages.insert(hit.module_output.messages.begin(), hit.front_messages.begin(), hit.front_messages.end());
      binaries_[b].output = std::make_shared<const JobOutput>(std::move(hit.module_output));
      results_.module_of[b] = hit.module;
      ++remote_hits_;
    }
    remote->report_problems(sink_);  // here, so that a remote switched off is said before any compile message
  }

  // A finished job's input (its source text or its module) is not read again: free it now, not when the build
  // ends (`= {}` would keep the capacity).
  void release_input(size_t j) {
    std::string().swap(jobs_[j].source);
    std::vector<uint32_t>().swap(jobs_[j].spirv);
  }

  void back_end_done(size_t j, WorkerOutcome outcome) {
    CompiledModule& module = results_.modules[job_subject_[j]];
    module.settled = true;
    module.fresh = outcome.kind == WorkerOutcome::Kind::Done && outcome.output.ok;
    if (module.fresh) {
      if (outcome.output.full_legalization) ++report_.full_legalizations;
      module.output = std::make_shared<const JobOutput>(std::move(outcome.output));
    } else {
      module.failure = std::move(outcome);
    }
    for (size_t b : module.waiting) settle(b, module, jobs_[j].spirv);
    module.waiting = {};
    release_input(j);
  }

  void front_end_done(size_t j, WorkerOutcome outcome) {
    release_input(j);
    const size_t b = job_subject_[j];
    results_.front_end_ran[b] = true;
    if (outcome.kind != WorkerOutcome::Kind::Done || !outcome.output.ok) {
      fail(b, outcome, nullptr);
      count_done();
      return;
    }
    const StageSource& s = sources_.list[binaries_[b].source];
    for (const FrontendMessage& m : outcome.output.messages)
      if (m.severity == Severity::Warning)
        messages_.collect(DiagId::HlslWarning, locator_.located(m, ""), m.text, variant_description(plan_, s),
                          sources_.list.size() + b);
    results_.front_messages[b] = std::move(outcome.output.messages);
    const std::vector<uint32_t>& spirv = outcome.output.spirv;
    Hasher module_key;
    Hash128 key = settings_.add_compile_options(module_key, plan_.pack.passes[s.pass], binaries_[b].stage)
                      .add(std::string_view(reinterpret_cast<const char*>(spirv.data()), spirv.size() * 4))
                      .finish();
    auto [it, inserted] = module_by_key_.emplace(key, results_.modules.size());
    results_.module_of[b] = key;
    if (inserted) {
      CompiledModule module;
      module.key = key;
      if (services_.remote && options_.remote.upload)
        module.remote_key = remote_module_key(*services_.remote, settings_, plan_.pack.passes[s.pass], binaries_[b].stage, spirv);
      if (services_.cache) {
        bool rejected = false;
        if (auto cached = services_.cache->load(key, rejected)) {
          module.settled = true;
          module.output = std::make_shared<const JobOutput>(std::move(*cached));
          ++report_.back_end_hits;
        }
        if (rejected) ++report_.cache_rejected;
      }
      if (!module.settled) {
        CompileJob back;
        back.id = results_.modules.size();
        back.kind = JobKind::BackEnd;
        back.stage = jobs_[j].stage;
        back.entry_point = jobs_[j].entry_point;
        back.source_name = jobs_[j].source_name;
        back.spirv = std::move(outcome.output.spirv);  // `spirv` is not read again on this path
        back.targets = jobs_[j].targets;
        back.optimize = jobs_[j].optimize;
        back.optimizer_recipe = jobs_[j].optimizer_recipe;
        back.bindings = jobs_[j].bindings;
        jobs_.push_back(std::move(back));  // runs next, in whichever worker is free
        job_subject_.push_back(results_.modules.size());
        ++report_.back_ends;
      }
      results_.modules.push_back(std::move(module));
    }
    CompiledModule& module = results_.modules[it->second];
    if (module.settled) settle(b, module, spirv);
    else module.waiting.push_back(b);
  }

  void count_done() {
    ++done_;
    if (options_.progress) options_.progress(done_, binaries_.size(), report_.cache_hits);
  }

  // A binary whose module has settled is done: it shares the module's output, or reports its failure.
  void settle(size_t b, const CompiledModule& module, const std::vector<uint32_t>& spirv) {
    if (module.output) binaries_[b].output = module.output;
    else fail(b, module.failure, &spirv);
    count_done();
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
    const std::string entry_name = display_path(plan_.declarations[s.pass].entry);
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
    } else if (first != outcome.output.messages.end()) {
      std::string prefix = id == DiagId::HlslError ? "" : step + ": ";
      messages_.collect(id, locator_.located(*first, entry_name), prefix + first->text, variant, order);
    } else {
      messages_.collect(id, SourceLocation{entry_name, 0, 0}, step + " failed", variant, order);
    }
  }

  // A reproducer next to the outputs: the exact preprocessed source the worker was given, and for a back-end
  // death the module it was given too, with the SPIRV-Tools commands that replay the back end.
  void internal_compiler_error(const Binary& binary, const StageSource& s, const std::string& variant,
                               const std::string& detail, const std::vector<uint32_t>* module) {
    report_.internal_errors = true;
    std::filesystem::path dir = options_.output_dir / "kiln-ice";
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    const std::string base = plan_.pack.passes[s.pass].name + "." + std::string(stage_name(s.stage)) + "." + keywords_slug(s.defines);
    std::filesystem::path repro = dir / (base + ".hlsl");
    std::string header = "// kiln internal compiler error: the compiler worker " + detail + "\n// " + variant +
                         ", entry point " + binary.entry_point + "\n// reproduce: glslangValidator -D -V -S " +
                         (s.stage == Stage::Vertex ? "vert" : "frag") + " -e " + binary.entry_point + " " +
                         repro.filename().string() + "\n";
    std::vector<std::string> notes;
    std::vector<std::string> unwritten;  // a reproducer that could not be written is said, not dropped
    if (module) {
      std::filesystem::path spv = dir / (base + ".spv");
      std::string error =
          write_file_atomic(spv, std::string_view(reinterpret_cast<const char*>(module->data()), module->size() * 4));
      header += "// the front end succeeded; the worker died in the back end, given " + spv.filename().string() +
                ":\n// spirv-opt --legalize-hlsl " + base + ".spv -o legal.spv && spirv-val --target-env " + kTargetEnvironment.spirv_env +
                " legal.spv && spirv-opt -O legal.spv -o opt.spv && spirv-cross opt.spv\n";
      if (error.empty()) notes.push_back("the front end's SPIR-V module (the back end's input) written to " + spv.string());
      else unwritten.push_back("the front end's SPIR-V module could not be written: " + error);
    }
    if (std::string error = write_file_atomic(repro, header + s.text); error.empty())
      notes.insert(notes.begin(), "reproducer written to " + repro.string());
    else
      unwritten.insert(unwritten.begin(), "the reproducer could not be written: " + error);
    notes.insert(notes.end(), unwritten.begin(), unwritten.end());
    notes.push_back("this is a bug in the compiler, not in your shader");
    sink_.report(DiagId::InternalCompilerError, SourceLocation{display_path(plan_.declarations[s.pass].entry), 0, 0},
                 "internal compiler error: the compiler worker " + detail + " while compiling " + variant, notes);
  }

  const Plan& plan_;
  const BuildOptions& options_;
  const BuildSettings& settings_;
  StageSources& sources_;
  std::vector<Binary>& binaries_;
  CompileServices services_;
  const SourceLocator& locator_;
  MessageGroups& messages_;
  DiagnosticSink& sink_;
  BuildReport& report_;

  CompileResults results_;
  std::vector<CompileJob> jobs_;
  std::vector<size_t> job_subject_;  // FrontEnd job -> binary, BackEnd job -> module
  std::map<Hash128, size_t> module_by_key_;
  size_t done_ = 0;
  size_t remote_hits_ = 0;
};

}  // namespace

CompileResults compile_binaries(const Plan& plan, const BuildOptions& options, const BuildSettings& settings,
                                StageSources& sources, std::vector<Binary>& binaries, CompileServices services,
                                const SourceLocator& locator, MessageGroups& messages, DiagnosticSink& sink,
                                BuildReport& report) {
  StageTimer timer(report, "compile");
  return Scheduler(plan, options, settings, sources, binaries, services, locator, messages, sink, report).run();
}

void store_in_cache(Cache& cache, bool memos, const CompileResults& results, const StageSources& sources,
                    const std::vector<Binary>& binaries, bool user_errors, unsigned threads, DiagnosticSink& sink,
                    BuildReport& report) {
  report.cache_rejected += cache.unreadable_segments();
  if (report.cache_rejected)
    sink.report(DiagId::CacheEntryRejected, SourceLocation{cache.directory().string(), 0, 0},
                std::to_string(report.cache_rejected) + " cache entr" + (report.cache_rejected == 1 ? "y was" : "ies were") +
                    " corrupt, truncated or foreign: compiled again and rewritten",
                {"nothing of them reached the outputs; if this repeats, check the disk or what else writes to the cache"});
  if (user_errors) return;
  // Entries are encoded on every core (the workers are done by now), then written as one segment file.
  StageTimer timer(report, "cache store");
  parallel_for(results.modules.size(), threads, [&](size_t m) {
    if (results.modules[m].fresh) cache.store(results.modules[m].key, *results.modules[m].output);
  });
  // A binary has an output only when its module's result is good (compiled now or already cached).
  parallel_for(binaries.size(), threads, [&](size_t b) {
    if (results.front_end_ran[b] && binaries[b].output)
      cache.store_alias(binaries[b].key, *results.module_of[b], results.front_messages[b]);
  });
  if (memos)
    parallel_for(sources.list.size(), threads, [&](size_t i) {
      const StageSource& s = sources.list[i];
      if (!s.preprocessed || !s.ok) return;
      PreprocessMemo memo{*s.key, {}};
      for (const std::string& name : s.files_read) {
        auto hash = sources.file_hashes.find(name);
        if (hash == sources.file_hashes.end()) return;  // not a file of the snapshot: no memo
        memo.files.emplace_back(name, hash->second);
      }
      cache.store_memo(s.memo, memo);
    });
  if (std::string error = cache.commit(); !error.empty())
    sink.report(DiagId::CacheUnwritable, SourceLocation{cache.directory().string(), 0, 0}, error,
                {"the outputs are unaffected; the next build compiles these variants again"});
}

}  // namespace kiln
