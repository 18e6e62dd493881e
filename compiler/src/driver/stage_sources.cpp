// SPDX-License-Identifier: Apache-2.0
#include "driver/stage_sources.hpp"

#include <algorithm>
#include <set>
#include <tuple>

#include "common/files.hpp"
#include "driver/build_context.hpp"

namespace kiln {
namespace {

// With -g, the files as written too: the module's OpSource holds them, so two sources that preprocess to the same
// text (they differ in a comment) are two results. A memo's key was made by this function when its files were
// what they are now, so it holds.
Hash128 source_key(const Plan& plan, const BuildSettings& settings, const StageSource& s) {
  Hasher key;
  settings.add_compile_options(key, plan.pack.passes[s.pass], s.stage).add(s.text);
  if (s.debug_files)
    for (const IncludableFile& file : *s.debug_files) key.add(file.name).add(file.text);
  return key.finish();
}

// "NAME=VALUE" per define of a pass, in order: Preprocess jobs carry them before the keywords.
std::vector<std::string> pass_defines(const PassDefinition& pass) {
  std::vector<std::string> out;
  for (const Define& define : pass.defines) out.push_back(define.name + "=" + define.value);
  return out;
}

// What a module with folded keywords (kiln/folded_keywords.hpp) sees of them. Macros, after the variant's keywords:
// each keyword is defined as itself, so that `defined(K)` holds and `K` names the bool (in an int group, the test
// `(_KilnGroup<id> == place)`, and KILN_GROUP_OF_<K> names the int), and KILN_FOLDED_<K> says that it is one (a
// shader that must also build K as a variant keyword tests it: docs/keywords.md). Declarations, before the
// preprocessed text (not preprocessed, so not expanded): a specialization constant per keyword (or int group) of the
// stage, and the block of the pass's dynamic branches, every member at its offset in every stage.
struct FoldedStage {
  std::vector<std::string> defines;
  std::shared_ptr<const std::string> declarations;
};

FoldedStage folded_stage(const std::vector<FoldedKeyword>& folded, Stage stage) {
  FoldedStage out;
  std::string constants, block;
  bool stage_has_branch = false;
  std::set<uint32_t> int_groups;
  for (const FoldedKeyword& k : folded) {
    const bool here = k.stages & stage_bit(stage);
    if (k.kind == KeywordKind::SpecializationInteger) {
      if (!here) continue;
      const std::string name = "_KilnGroup" + std::to_string(k.slot);
      if (int_groups.insert(k.slot).second)
        constants += "[[vk::constant_id(" + std::to_string(k.slot) + ")]] const int " + name + " = " +
                     std::to_string(k.fallback) + ";\n";
      if (k.keyword.empty()) continue;
      out.defines.push_back(k.keyword + "=(" + name + " == " + std::to_string(k.value) + ")");
      out.defines.push_back("KILN_GROUP_OF_" + k.keyword + "=" + name);
      out.defines.push_back("KILN_FOLDED_" + k.keyword);
      continue;
    }
    if (here) {
      out.defines.push_back(k.keyword + "=" + k.keyword);
      out.defines.push_back("KILN_FOLDED_" + k.keyword);
    }
    if (k.kind == KeywordKind::SpecializationConstant) {
      if (here) constants += "[[vk::constant_id(" + std::to_string(k.slot) + ")]] const bool " + k.keyword + " = false;\n";
    } else {
      block += "    bool " + k.keyword + ";\n";
      stage_has_branch = stage_has_branch || here;
    }
  }
  if (stage_has_branch)
    constants += "[[vk::binding(" + std::to_string(kKeywordBlockBinding) + ", " + std::to_string(kKeywordBlockSet) +
                 ")]] cbuffer " + std::string(kKeywordBlockName) + "\n{\n" + block + "};\n";
  // The source's own lines keep their numbers.
  if (!constants.empty()) out.declarations = std::make_shared<const std::string>(constants + "#line 1\n");
  return out;
}

StageSources enumerate(const Plan& plan) {
  StageSources out;
  std::map<std::tuple<uint32_t, Stage, std::vector<std::string>>, size_t> index;
  out.variant_source.resize(plan.passes.size());
  for (uint32_t p = 0; p < plan.passes.size(); ++p) {
    const auto& variants = plan.expansions[p].variants;
    out.variant_source[p].resize(variants.size());
    // Folded groups choose no module: the variant's keywords of the other groups, then the folded macros.
    std::vector<KeywordGroup> module_groups = plan.passes[p].groups;
    for (KeywordGroup& group : module_groups)
      if (is_folded(group.kind())) group.stages = 0;
    const std::vector<FoldedKeyword> folded = folded_keywords(plan.keyword_group_records(p));
    std::array<FoldedStage, kStageCount> folded_stages;
    for (Stage s : kAllStages) folded_stages[static_cast<size_t>(s)] = folded_stage(folded, s);
    for (size_t v = 0; v < variants.size(); ++v) {
      for (Stage s : kAllStages) {
        int& slot = out.variant_source[p][v][static_cast<size_t>(s)];
        slot = -1;
        if (plan.entry_point(p, s).empty()) continue;
        ++out.stage_instances;
        const FoldedStage& folded_stage = folded_stages[static_cast<size_t>(s)];
        auto defines = enabled_keywords(module_groups, variants[v], s);
        defines.insert(defines.end(), folded_stage.defines.begin(), folded_stage.defines.end());
        auto [it, inserted] = index.emplace(std::make_tuple(p, s, defines), out.list.size());
        if (inserted) {
          out.list.push_back(StageSource{p, s, defines, v});
          out.list.back().folded = folded_stage.declarations;
        }
        slot = static_cast<int>(it->second);
      }
    }
  }
  return out;
}

// A stage source whose memo is in the cache, with every file it read unchanged, is not preprocessed: its key
// comes from the memo, and its text is made only if the cache does not have its result. The memo key covers
// the versions, options, stage, entry point, defines, working directory (names in #line) and the list of every
// file the scan found (a new file could change what an #include finds).
void use_memos(StageSources& sources, const Plan& plan, const BuildSettings& settings, Cache& cache) {
  Hasher listing;
  std::error_code cwd_error;
  listing.add(std::filesystem::current_path(cwd_error).string());
  for (const auto& [path, file] : plan.sources.files) {
    listing.add(path.string());
    sources.file_hashes[display_path(path)] = hash64(file.text);
  }
  const std::string files_listed = listing.finish().hex();
  for (StageSource& s : sources.list) {
    Hasher memo;
    settings.add_compile_options(memo.add("preprocess"), plan.pack.passes[s.pass], s.stage)
        .add(display_path(plan.declarations[s.pass].stage_entry[static_cast<size_t>(s.stage)]))
        .add(files_listed);
    for (const std::string& define : pass_defines(plan.pack.passes[s.pass])) memo.add(define);
    for (const std::string& define : s.defines) memo.add(define);
    if (s.folded) memo.add(*s.folded);
    s.memo = memo.finish();
    std::optional<PreprocessMemo> known = cache.load_memo(s.memo, [&](const PreprocessMemo& candidate) {
      return !candidate.files.empty() && std::all_of(candidate.files.begin(), candidate.files.end(), [&](const auto& file) {
               auto it = sources.file_hashes.find(file.first);
               return it != sources.file_hashes.end() && it->second == file.second;
             });
    });
    if (!known) continue;
    s.ok = true;
    s.key = known->source_key;
    ++sources.memo_hits;
  }
}

}  // namespace

std::string variant_description(const Plan& plan, const StageSource& s) {
  return variant_description(plan, s.pass, s.stage, s.defines);
}

// A folded keyword's macros (K=...) are named by their KILN_FOLDED_K alone: a file name has no '=', space or '('.
std::string keywords_slug(const std::vector<std::string>& keywords) {
  std::string out;
  for (const std::string& k : keywords)
    if (k.find('=') == std::string::npos) out += (out.empty() ? "" : "+") + k;
  return out.empty() ? "_" : out;
}

Preprocessor::Preprocessor(const Plan& plan, const BuildSettings& settings, JobRunner& runner, const BuildContext& build,
                           WorkerLimits limits)
    : plan_(plan), settings_(settings), runner_(runner), build_(build), limits_(std::move(limits)),
      pass_files_(plan.passes.size()) {}

std::shared_ptr<const std::vector<IncludableFile>> Preprocessor::files_of(uint32_t pass, Stage stage) {
  auto& cached = pass_files_[pass][static_cast<size_t>(stage)];
  if (!cached) {
    auto files = std::make_shared<std::vector<IncludableFile>>();
    const PassDeclarations& declarations = plan_.declarations[pass];
    std::vector<std::filesystem::path> order{declarations.stage_entry[static_cast<size_t>(stage)]};
    for (const std::filesystem::path& path : declarations.files)
      if (path != order.front()) order.push_back(path);
    for (const std::filesystem::path& path : order) {
      const SourceFile* file = plan_.sources.find(path);
      if (!file) continue;
      IncludableFile served{display_path(path), file->text, file->pragma_once, {}};
      for (const auto& [name, target] : file->includes) served.includes.emplace(name, display_path(target));
      files->push_back(std::move(served));
    }
    cached = std::move(files);
  }
  return cached;
}

std::shared_ptr<const std::vector<IncludableFile>> Preprocessor::files_read(const StageSource& s) const {
  auto out = std::make_shared<std::vector<IncludableFile>>();
  const auto& files = pass_files_[s.pass][static_cast<size_t>(s.stage)];
  if (!files) return out;
  const std::set<std::string> read(s.files_read.begin(), s.files_read.end());
  for (const IncludableFile& file : *files)
    if (read.count(file.name)) out->push_back({file.name, file.text, file.once, {}});
  return out;
}

CompileJob Preprocessor::job(const StageSources& sources, size_t index) {
  const StageSource& s = sources.list[index];
  CompileJob job;
  job.id = index;
  job.kind = JobKind::Preprocess;
  job.stage = s.stage;
  job.files = files_of(s.pass, s.stage);
  job.defines = pass_defines(plan_.pack.passes[s.pass]);  // the pass's defines, then the keywords
  job.defines.insert(job.defines.end(), s.defines.begin(), s.defines.end());
  return job;
}

void Preprocessor::finished(StageSource& s, WorkerOutcome outcome) const {
  const std::string entry_name = display_path(plan_.declarations[s.pass].stage_entry[static_cast<size_t>(s.stage)]);
  s.preprocessed = true;
  s.ok = false;
  if (outcome.kind == WorkerOutcome::Kind::Done && outcome.output.failed_step == CompileStep::Internal) {
    s.internal_error = "threw an exception (" +
                       (outcome.output.messages.empty() ? std::string("no message") : outcome.output.messages[0].text) + ")";
    write_reproducer(s);
  } else if (outcome.kind == WorkerOutcome::Kind::Done) {
    s.ok = outcome.output.ok;
    s.text = s.folded ? *s.folded + outcome.output.preprocessed : std::move(outcome.output.preprocessed);
    s.messages = std::move(outcome.output.messages);
    s.files_read = std::move(outcome.output.files_read);
    if (s.ok && settings_.debug_info) s.debug_files = files_read(s);
    if (s.ok) s.key = source_key(plan_, settings_, s);
  } else if (outcome.kind == WorkerOutcome::Kind::OutOfMemory) {
    s.messages = {{Severity::Error, entry_name, 0,
                   "preprocessing needed more than the compiler worker's " + std::to_string(limits_.memory_limit_mb) +
                       " MiB (a macro that expands exponentially?)"}};
  } else if (outcome.kind == WorkerOutcome::Kind::TimedOut) {
    s.messages = {{Severity::Error, entry_name, 0,
                   "preprocessing took longer than the compiler worker's " +
                       std::to_string(limits_.job_timeout.count() / 1000) + " s (a macro that expands exponentially?)"}};
  } else {
    s.internal_error = outcome.detail;  // the preprocessor crashed: a bug in it, not in the shader
    write_reproducer(s);
  }
}

void Preprocessor::write_reproducer(StageSource& s) const {
  const std::filesystem::path entry = plan_.declarations[s.pass].stage_entry[static_cast<size_t>(s.stage)];
  const SourceFile* file = plan_.sources.find(entry);
  std::vector<std::string> defines = pass_defines(plan_.pack.passes[s.pass]);
  defines.insert(defines.end(), s.defines.begin(), s.defines.end());
  std::string command = "glslangValidator -E";
  std::string preamble;
  for (const std::string& define : defines) {
    const size_t equals = define.find('=');
    command += " -D" + define;
    // As the front end's preamble writes it: a keyword is defined as 1.
    preamble += "#define " + define.substr(0, equals) + (equals == std::string::npos ? " 1" : " " + define.substr(equals + 1)) + "\n";
  }
  const std::filesystem::path& dir = build_.reproducers;
  const std::filesystem::path repro =
      dir / (plan_.pack.passes[s.pass].name + "." + std::string(stage_name(s.stage)) + "." + keywords_slug(s.defines) +
             ".preprocess.hlsl");
  const std::string text = "// kiln internal compiler error: the compiler worker " + s.internal_error +
                           " while preprocessing " + variant_description(plan_, s) + "\n// reproduce (from " +
                           display_path(entry.parent_path()) + "): " + command + " " + entry.filename().string() +
                           "\n// below: the defines, then " + display_path(entry) + " as the build read it\n" +
                           preamble + "#line 1\n" + (file ? file->text : std::string());
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (Result<void> written = write_output_file(repro, text))
    s.internal_notes.push_back("reproducer written to " + repro.string());
  else
    s.internal_notes.push_back("the reproducer could not be written: " + written.error().message);
}

void Preprocessor::run(StageSources& sources, const std::vector<size_t>& which) {
  if (which.empty()) return;
  std::vector<CompileJob> jobs;
  for (size_t index : which) jobs.push_back(job(sources, index));
  runner_.run(jobs, [&](size_t j, WorkerOutcome outcome) {
    finished(sources.list[which[j]], std::move(outcome));
    std::vector<std::string>().swap(jobs[j].defines);
  });
}

size_t count_stage_sources(const Plan& plan) { return enumerate(plan).list.size(); }

StageSources enumerate_stage_sources(const Plan& plan, const BuildSettings& settings, Cache* memo_cache) {
  const auto started = std::chrono::steady_clock::now();
  StageSources sources = enumerate(plan);
  sources.enumerated_from = started;
  if (memo_cache) use_memos(sources, plan, settings, *memo_cache);
  return sources;
}

StageSources prepare_stage_sources(BuildContext& build, const Plan& plan, const BuildSettings& settings,
                                   Cache* memo_cache, Preprocessor& preprocessor) {
  StageTimer timer(build, "preprocess");
  StageSources sources = enumerate_stage_sources(plan, settings, memo_cache);
  std::vector<size_t> pending;
  for (size_t i = 0; i < sources.list.size(); ++i)
    if (!sources.list[i].key) pending.push_back(i);
  preprocessor.run(sources, pending);
  return sources;
}

void report_preprocess_failure(const StageSource& s, size_t order, const Plan& plan, const SourceLocator& locator,
                               MessageGroups& messages, DiagnosticSink& sink) {
  const std::string entry_name = display_path(plan.declarations[s.pass].stage_entry[static_cast<size_t>(s.stage)]);
  if (!s.internal_error.empty()) {
    std::vector<std::string> notes = s.internal_notes;
    notes.push_back("this is a bug in the compiler, not in your shader");
    sink.report(DiagId::InternalCompilerError, SourceLocation{entry_name, 0, 0},
                "internal compiler error: the compiler worker " + s.internal_error + " while preprocessing " +
                    variant_description(plan, s),
                notes);
    return;
  }
  auto first = std::find_if(s.messages.begin(), s.messages.end(),
                            [](const FrontendMessage& m) { return m.severity == Severity::Error; });
  if (first == s.messages.end())  // failed without saying why: still an error, never a silently missing variant
    messages.collect(DiagId::PreprocessorError, SourceLocation{entry_name, 0, 0}, "preprocessing failed",
                     variant_description(plan, s), order);
  else
    messages.collect(DiagId::PreprocessorError, locator.located(*first, entry_name), first->text, variant_description(plan, s),
                     order);
}

std::vector<uint32_t> source_shares(const StageSources& sources, unsigned count) {
  // Within a pass and stage, in the order of each source's identity hash, not of enumeration: the variants enumerate
  // in mixed radix, so dealing them in that order gave each share the same values of the last groups (16 shards of
  // the default pack took 1.88 to 2.53 s; dealt by hash, 1.70 to 1.86 s).
  std::vector<std::tuple<uint32_t, Stage, uint64_t, size_t>> order;
  for (size_t i = 0; i < sources.list.size(); ++i)
    order.emplace_back(sources.list[i].pass, sources.list[i].stage, source_identity(sources.list[i]), i);
  std::sort(order.begin(), order.end());
  std::vector<uint32_t> shares(order.size(), 0);
  for (size_t position = 0; position < order.size(); ++position)
    shares[std::get<3>(order[position])] = static_cast<uint32_t>(position % std::max(1u, count));
  return shares;
}

uint64_t source_identity(const StageSource& s) {
  Hasher identity;
  identity.add(std::to_string(s.pass)).add(stage_name(s.stage));
  for (const std::string& define : s.defines) identity.add(define);
  identity.add(s.folded ? *s.folded : std::string());
  return identity.finish().low;
}

std::vector<Binary> dedupe_stage_sources(BuildContext& build, StageSources& sources, const Plan& plan,
                                         const SourceLocator& locator, MessageGroups& messages) {
  StageTimer timer(build, "dedupe");
  std::vector<Binary> binaries;
  std::map<Hash128, size_t> by_key;
  for (size_t i = 0; i < sources.list.size(); ++i) {
    StageSource& s = sources.list[i];
    if (s.elsewhere) continue;
    if (!s.ok) {
      report_preprocess_failure(s, i, plan, locator, messages, build.sink);
      continue;
    }
    const Hash128 key = *s.key;
    auto [it, inserted] = by_key.emplace(key, binaries.size());
    if (inserted) binaries.push_back(Binary{key, s.stage, plan.entry_point(s.pass, s.stage), i, {}, nullptr});
    binaries[it->second].sources.push_back(i);
    s.binary = static_cast<int>(it->second);
  }
  return binaries;
}

}  // namespace kiln
