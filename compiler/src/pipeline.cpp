// The kiln pipeline, top to bottom. Each stage lives in its own folder; this file lists them once:
//   0 load definitions   definition/
//   1 declarations       declarations/   (scan the include graph, collect #pragma keyword groups)
//   2 expand             permutations/   (count, then enumerate per pass)
//   3 strip              permutations/   (constraints, scene profiles, budget)
//   4 preprocess+dedupe  preprocess/ frontend/  (per stage, only the keywords the stage sees)
//   5 compile            workers/ frontend/ optimize/   (in worker processes; cached)
//   6 cross-compile      cross/          (inside the workers)
//   7 reflect            reflect/        (inside the workers; layouts merged and checked here)
//   8 pack               pack/
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <map>
#include <thread>

#include "cache/cache.hpp"
#include "common/files.hpp"
#include "common/hash.hpp"
#include "common/parallel.hpp"
#include "cross/cross_compile.hpp"
#include "declarations/declarations.hpp"
#include "definition/definition.hpp"
#include "frontend/frontend.hpp"
#include "kiln/build.hpp"
#include "kiln/pack_format.hpp"
#include "optimize/spirv_tools.hpp"
#include "pack/pack_writer.hpp"
#include "permutations/permutations.hpp"
#include "reflect/reflect.hpp"
#include "remote/remote_cache.hpp"
#include "workers/worker_pool.hpp"

namespace kiln {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

class StageTimer {
 public:
  StageTimer(BuildReport& report, std::string stage) : report_(report), stage_(std::move(stage)), start_(Clock::now()) {}
  ~StageTimer() {
    report_.timings.push_back({stage_, std::chrono::duration<double, std::milli>(Clock::now() - start_).count()});
  }

 private:
  BuildReport& report_;
  std::string stage_;
  Clock::time_point start_;
};

// Stages 0-3, shared by `kiln build` and `kiln list`.
struct Plan {
  PackDefinition pack;
  std::vector<SceneProfile> scenes;
  SourceSet sources;
  std::unique_ptr<IncludeRoots> roots;
  std::vector<PassDeclarations> declarations;
  std::vector<PassKeywords> passes;
  std::vector<PassExpansion> expansions;
  std::vector<StripLine> strip;
  Funnel funnel;
};

std::unique_ptr<Plan> make_plan(const BuildOptions& options, DiagnosticSink& sink, BuildReport& report) {
  auto plan = std::make_unique<Plan>();
  ReadLimits limits{options.max_file_bytes};
  {
    StageTimer timer(report, "load");
    auto pack = load_pack_definition(options.pack_file, limits, sink);
    bool ok = pack.has_value();
    for (const auto& file : options.scene_files) {
      auto scene = load_scene_profile(file, limits, sink);
      if (scene) plan->scenes.push_back(std::move(*scene));
      else ok = false;
    }
    if (!ok) return nullptr;
    plan->pack = std::move(*pack);
    for (SceneProfile& scene : plan->scenes)
      ok = resolve_scene_profile(scene, plan->pack.scene_features_json, plan->pack.materials, sink) && ok;
    if (!ok) return nullptr;
  }
  {
    StageTimer timer(report, "declarations");
    std::vector<std::filesystem::path> roots = plan->pack.include_dirs;
    for (const PassDefinition& pass : plan->pack.passes) roots.push_back(pass.source.parent_path());
    plan->roots = std::make_unique<IncludeRoots>(roots);
    bool ok = true;
    for (const PassDefinition& pass : plan->pack.passes) {
      std::error_code ec;
      if (!std::filesystem::exists(pass.source, ec)) {
        sink.report(DiagId::FileUnreadable, pass.defined_at,
                    "pass '" + pass.name + "': source file '" + pass.source.string() + "' does not exist");
        ok = false;
        continue;
      }
      auto declarations = scan_declarations(pass.source, *plan->roots, limits, plan->sources, sink);
      if (!declarations) {
        ok = false;
        continue;
      }
      plan->passes.push_back(PassKeywords{&pass, declarations->groups});
      plan->declarations.push_back(std::move(*declarations));
    }
    if (!ok) return nullptr;
  }
  {
    StageTimer timer(report, "expand+strip");
    if (!check_rule_keywords(plan->passes, plan->pack, plan->scenes, sink)) return nullptr;
    StripRules rules{&plan->pack.constraints, &plan->scenes, &plan->pack.materials};
    auto expansions = expand_and_strip(plan->passes, rules, plan->pack.budget, plan->pack, sink);
    if (!expansions) return nullptr;
    plan->expansions = std::move(*expansions);
    for (size_t p = 0; p < plan->expansions.size(); ++p) {
      const PassExpansion& e = plan->expansions[p];
      const std::string& pass = plan->pack.passes[p].name;
      for (const auto& effect : e.strip.constraints) {
        const Constraint& c = *effect.constraint;
        std::string rule = "constraint " + c.keyword;
        if (!c.requires_all.empty()) rule += " requires [" + join_keywords(c.requires_all) + "]";
        if (!c.requires_any.empty()) rule += " requires_any [" + join_keywords(c.requires_any) + "]";
        if (!c.excludes.empty()) rule += " excludes [" + join_keywords(c.excludes) + "]";
        plan->strip.push_back({pass, rule, "-" + effect.removed.text(), c.reason});
      }
      if (!plan->pack.materials.empty() && (e.valid.saturated || e.strip.after_materials.value != e.valid.value))
        plan->strip.push_back({pass, "materials (" + std::to_string(plan->pack.materials.size()) + " presets)",
                               e.valid.text() + " -> " + e.strip.after_materials.text(),
                               "shader_feature combinations no material uses"});
      if (!plan->scenes.empty())
        plan->strip.push_back({pass, "scenes (" + std::to_string(plan->scenes.size()) + ")",
                               e.strip.after_materials.text() + " -> " + e.kept.text(), "keywords no scene enables"});
    }
    for (const PassExpansion& e : plan->expansions) {
      plan->funnel.declared_saturated |= e.declared.saturated;
      plan->funnel.declared += e.declared.value;
      plan->funnel.valid += e.valid.value;
      plan->funnel.kept += e.kept.value;
    }
  }
  return plan;
}

// One (pass, stage, keywords the stage sees): preprocessed once, however many variants share it.
struct StageSource {
  uint32_t pass = 0;
  Stage stage = Stage::Vertex;
  std::vector<std::string> defines;
  size_t first_variant = 0;  // for messages
  bool ok = false;
  bool preprocessed = false;  // text holds the preprocessed source (not only known through a memo)
  std::string text;
  std::vector<FrontendMessage> messages;
  int binary = -1;
  std::optional<Hash128> key;            // the source's cache key: from the text, or from a memo
  Hash128 memo;                          // where its preprocessing memo is cached
  std::vector<std::string> files_read;   // display names, when preprocessed in this build
  std::string internal_error;            // the worker preprocessing it crashed: how
};

struct Binary {
  Hash128 key;
  Stage stage = Stage::Vertex;
  std::string entry_point;
  size_t source = 0;  // a StageSource that produced it
  std::vector<size_t> sources;
  std::shared_ptr<const JobOutput> output;  // shared by every binary whose front end gave the same module
};

std::string variant_description(const Plan& plan, const StageSource& s) {
  return "pass '" + plan.pack.passes[s.pass].name + "' " + std::string(stage_name(s.stage)) + " stage, keywords [" +
         join_keywords(s.defines) + "]";
}

std::string slug(const std::vector<std::string>& keywords) {
  if (keywords.empty()) return "_";
  std::string out;
  for (const std::string& k : keywords) out += (out.empty() ? "" : "+") + k;
  return out;
}

// Best-effort column: glslang gives only lines, but most messages quote the offending token.
bool is_directive(const std::string& line_text) {
  const size_t first = line_text.find_first_not_of(" \t");
  return first != std::string::npos && line_text[first] == '#';
}

// "';' : Expected" quotes the token glslang wanted, not the one it found: the caret would land on some other
// ';' of the line, so such a message gets no column (printed `path:line:`, never a made-up one).
int guess_column(const std::string& line_text, const std::string& message) {
  if (message.size() < 3 || message[0] != '\'') return 0;
  size_t close = message.find('\'', 1);
  if (close == std::string::npos || close == 1) return 0;
  if (message.compare(close, std::string::npos, "' : Expected") == 0) return 0;
  // A preprocessor error ('#define' : bad argument, 'preprocessor evaluation' : bad expression) is about the
  // directive of its line: the caret goes under its '#'.
  const std::string quoted = message.substr(1, close - 1);
  if (quoted.starts_with('#') || quoted == "preprocessor evaluation") {
    const size_t hash = line_text.find_first_not_of(" \t");
    return hash != std::string::npos && line_text[hash] == '#' ? static_cast<int>(hash) + 1 : 0;
  }
  std::string token = message.substr(1, close - 1);
  size_t at = line_text.find(token);
  return at == std::string::npos ? 0 : static_cast<int>(at) + 1;
}

std::string line_of(const SourceSet& sources, const std::map<std::string, std::filesystem::path>& by_name,
                    const std::string& path, int line) {
  auto it = by_name.find(path);
  if (it == by_name.end() || line <= 0) return {};
  const SourceFile* file = sources.find(it->second);
  if (!file) return {};
  size_t start = 0;
  for (int i = 1; i < line; ++i) {
    start = file->text.find('\n', start);
    if (start == std::string::npos) return {};
    ++start;
  }
  size_t end = file->text.find('\n', start);
  return file->text.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

// The first name quoted in a message ("buffer block 'C' is ...").
std::string quoted_name(const std::string& message) {
  const size_t open = message.find('\'');
  const size_t close = open == std::string::npos ? open : message.find('\'', open + 1);
  return close == std::string::npos ? std::string() : message.substr(open + 1, close - open - 1);
}

// Where a pass's sources first name `name` as a whole word outside comments: the declaration of a
// resource a back-end step reports on (SPIR-V keeps no source lines); the entry file when not found.
SourceLocation locate_declaration(const Plan& plan, uint32_t pass, const std::string& name, const std::string& entry_name) {
  if (name.empty()) return SourceLocation{entry_name, 0, 0};
  for (const std::filesystem::path& path : plan.declarations[pass].files) {
    const SourceFile* file = plan.sources.find(path);
    if (!file) continue;
    auto word_char = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
    std::vector<std::string> lines = code_lines(file->text);
    for (size_t l = 0; l < lines.size(); ++l) {
      for (size_t at = lines[l].find(name); at != std::string::npos; at = lines[l].find(name, at + 1)) {
        const bool starts = at == 0 || !word_char(lines[l][at - 1]);
        const size_t end = at + name.size();
        const bool ends = end == lines[l].size() || !word_char(lines[l][end]);
        if (starts && ends) return SourceLocation{display_path(path), static_cast<int>(l + 1), static_cast<int>(at + 1)};
      }
    }
  }
  return SourceLocation{entry_name, 0, 0};
}

std::string tools_fingerprint(Frontend& frontend) {
  return std::string("kiln ") + kKilnVersion + " (compile job revision " + std::to_string(kCompileJobRevision) + "); " +
         frontend.name() + " " + frontend.version() + "; " +
         spirv_tools_version() + "; SPIRV-Cross " + spirv_cross_version();
}

json keyword_group_json(const KeywordGroup& group) {
  json values = json::array();
  for (const std::string& v : group.values) values.push_back(v.empty() ? "_" : v);
  json stages = json::array();
  for (Stage s : kAllStages)
    if (group.stages & stage_bit(s)) stages.push_back(stage_name(s));
  return {{"pragma", group.pragma}, {"values", values}, {"stages", stages}};
}

// Recorded in the manifest so that tools (check-scene) can reason about a built pack on its own.
json constraints_json(const PackDefinition& pack) {
  json out = json::array();
  for (const Constraint& c : pack.constraints) {
    json item{{"keyword", c.keyword}};
    if (!c.requires_all.empty()) item["requires"] = c.requires_all;
    if (!c.requires_any.empty()) item["requires_any"] = c.requires_any;
    if (!c.excludes.empty()) item["excludes"] = c.excludes;
    if (!c.reason.empty()) item["reason"] = c.reason;
    out.push_back(item);
  }
  return out;
}

json materials_json(const PackDefinition& pack) {
  json out = json::array();
  for (const MaterialPreset& m : pack.materials) out.push_back({{"name", m.name}, {"keywords", m.keywords}});
  return out;
}

std::string depfile_escape(const std::string& path) {
  std::string out;
  for (char c : path) {
    if (c == ' ' || c == '#') out += '\\';
    if (c == '$') out += '$';
    out += c;
  }
  return out;
}

// The stamp (<name>.stamp) records the inputs hash, the size and mtime of the manifest, and the name, size
// and mtime of the archive it was written with: a no-change rebuild compares a few numbers instead of
// re-reading a large pack.
std::string file_signature(const std::filesystem::path& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return "missing";
  return std::to_string(info.st_size) + ":" + std::to_string(info.st_mtim.tv_sec) + "." + std::to_string(info.st_mtim.tv_nsec);
}

std::filesystem::path stamp_path(const std::filesystem::path& directory, const std::string& name) {
  return directory / (name + ".stamp");
}

std::string stamp_text(const std::filesystem::path& directory, const std::string& name, const std::string& archive_file,
                       const std::string& inputs_hash) {
  return inputs_hash + "\n" + file_signature(manifest_path(directory, name)) + "\n" + archive_file + "\n" +
         file_signature(directory / archive_file) + "\n";
}

// The pack's archive file name when the pack in `directory` is the one the stamp was written with, for these
// inputs; nothing when it must be built.
std::optional<std::string> current_archive(const std::filesystem::path& directory, const std::string& name,
                                           const std::string& inputs_hash) {
  auto stamp = read_binary_file(stamp_path(directory, name));
  if (!stamp) return std::nullopt;
  const size_t first = stamp->find('\n'), second = first == std::string::npos ? first : stamp->find('\n', first + 1),
               third = second == std::string::npos ? second : stamp->find('\n', second + 1);
  if (third == std::string::npos) return std::nullopt;
  std::string archive_file = stamp->substr(second + 1, third - second - 1);
  if (!is_archive_file_name(archive_file, name) || *stamp != stamp_text(directory, name, archive_file, inputs_hash))
    return std::nullopt;
  return archive_file;
}

// -j: worker processes (preprocessing and compiling), and the threads of the stages that run in kiln itself
// (cache, pack).
unsigned parallelism(const BuildOptions& options) {
  return options.jobs ? options.jobs : std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace

int exit_code(const DiagnosticSink& sink, bool internal_errors) {
  if (internal_errors) return 2;
  return sink.has_errors() ? 1 : 0;
}

std::optional<PlanListing> list_variants(const BuildOptions& options, DiagnosticSink& sink) {
  BuildReport report;
  auto plan = make_plan(options, sink, report);
  if (!plan) return std::nullopt;
  PlanListing listing;
  listing.pack = plan->pack.name;
  listing.funnel = plan->funnel;
  for (size_t p = 0; p < plan->passes.size(); ++p)
    listing.pass_groups.emplace_back(plan->pack.passes[p].name, plan->passes[p].groups);
  for (const auto& [path, file] : plan->sources.files) listing.sources.emplace_back(display_path(path), file.text);
  for (const SceneProfile& scene : plan->scenes) listing.scenes.emplace_back(scene.name, scene.keywords);
  for (size_t p = 0; p < plan->passes.size(); ++p) {
    const auto& groups = plan->passes[p].groups;
    for (const Variant& v : plan->expansions[p].variants) {
      VariantListing item;
      item.pass = plan->pack.passes[p].name;
      item.keywords = enabled_keywords(groups, v);
      for (Stage s : kAllStages)
        if (!plan->pack.passes[p].entry_points[static_cast<size_t>(s)].empty())
          item.stage_keywords.emplace_back(std::string(stage_name(s)), enabled_keywords(groups, v, s));
      listing.variants.push_back(std::move(item));
    }
  }
  return listing;
}

BuildReport build_pack(const BuildOptions& options, DiagnosticSink& sink) {
  BuildReport report;
  const auto start = Clock::now();
  auto finish = [&] {
    report.timings.push_back({"total", std::chrono::duration<double, std::milli>(Clock::now() - start).count()});
    return report;
  };

  // Stages 0-3: definitions, declarations, expansion, stripping.
  auto plan = make_plan(options, sink, report);
  if (!plan) return finish();
  report.funnel = plan->funnel;
  report.strip_report = plan->strip;
  report.dependencies.push_back(std::filesystem::absolute(options.pack_file));
  for (const auto& scene : options.scene_files) report.dependencies.push_back(std::filesystem::absolute(scene));
  for (const auto& [path, file] : plan->sources.files) report.dependencies.push_back(path);

  // The output directory must be writable before any work is spent.
  std::error_code ec;
  std::filesystem::create_directories(options.output_dir, ec);
  if (ec || ::access(options.output_dir.c_str(), W_OK) != 0) {
    sink.report(DiagId::OutputUnwritable, SourceLocation{options.output_dir.string(), 0, 0},
                "output directory '" + options.output_dir.string() + "' is not writable" +
                    (ec ? ": " + ec.message() : std::string()));
    return finish();
  }
  auto write_depfile = [&]() {
    if (!options.depfile) return;
    std::string text = depfile_escape(manifest_path(options.output_dir, plan->pack.name).string()) + ":";
    for (const auto& dep : report.dependencies) text += " \\\n  " + depfile_escape(dep.string());
    if (std::string error = write_file_atomic(*options.depfile, text + "\n"); !error.empty())
      sink.report(DiagId::OutputUnwritable, SourceLocation{options.depfile->string(), 0, 0}, error);
  };

  auto frontend = make_frontend(options.frontend);
  if (!frontend) {
    std::string known;
    for (const std::string& name : frontend_names()) known += (known.empty() ? "" : ", ") + name;
    sink.report(DiagId::UnknownFrontend, SourceLocation{options.pack_file.string(), 0, 0},
                "no front end named '" + options.frontend + "' (kiln has: " + known + ")");
    return finish();
  }
  const std::string fingerprint = tools_fingerprint(*frontend);
  std::vector<Target> targets = options.targets.empty() ? plan->pack.targets : options.targets;
  if (std::find(targets.begin(), targets.end(), Target::Spirv) == targets.end()) targets.insert(targets.begin(), Target::Spirv);
  std::sort(targets.begin(), targets.end());

  // Up to date? The inputs hash covers tools, options, the pack format (a pack another format version wrote
  // is rebuilt) and the bytes of every file read.
  std::string target_names;
  for (Target t : targets) target_names += std::string(target_name(t)) + ",";
  auto add_inputs = [&](auto& hasher) {  // a Hasher here, a RemoteKeyHasher for the remote's pack-level entry
    hasher.add(uint64_t{kPackFormatVersion});
    hasher.add(fingerprint).add(options.optimize ? 1 : 0).add(target_names).add(plan->pack.text);
    for (const SceneProfile& scene : plan->scenes) hasher.add(scene.text);
    for (const auto& [path, file] : plan->sources.files) hasher.add(path.string()).add(file.text);
  };
  Hasher inputs;
  add_inputs(inputs);
  const std::string inputs_hash = inputs.finish().hex();
  report.manifest = manifest_path(options.output_dir, plan->pack.name);
  if (auto archive_file = options.emit.empty() ? current_archive(options.output_dir, plan->pack.name, inputs_hash)
                                               : std::nullopt) {
    // A build killed after writing its archive, before or after its manifest's rename, left an orphan.
    remove_orphaned_archives(options.output_dir, plan->pack.name, *archive_file);
    report.up_to_date = true;
    report.ok = true;
    write_depfile();
    return finish();
  }

  std::optional<Cache> cache;
  if (options.cache_dir) cache.emplace(*options.cache_dir, options.cache_max_mb << 20);
  std::map<std::string, uint64_t> file_hashes;  // display name -> XXH3 of the text, for preprocessing memos
  const bool memos = cache && !options.emit.count("preprocessed");
  // The remote tier under the local cache (remote/): asked for local misses, written after a good build.
  std::unique_ptr<RemoteCache> remote = RemoteCache::open(options.remote, sink);
  // First its pack-level entry: the finished pack of these inputs, if a machine with the same checkout built it.
  std::optional<RemoteKey> pack_key;
  if (remote && remote->usable() && options.emit.empty()) {
    RemoteKeyHasher key;
    remote->start_key(key, "pack");
    add_inputs(key);
    pack_key = key.add(plan->pack.name).finish();
    std::optional<std::string> archive_file = remote->fetch_pack(*pack_key, options.output_dir, plan->pack.name);
    if (archive_file) {
      remote->report_problems(sink);
      report.remote = remote->report();
      remove_orphaned_archives(options.output_dir, plan->pack.name, *archive_file);
      write_file_atomic(stamp_path(options.output_dir, plan->pack.name),
                        stamp_text(options.output_dir, plan->pack.name, *archive_file, inputs_hash));
      report.ok = !sink.has_errors();
      write_depfile();
      return finish();
    }
  }

  // Stage 4: preprocess each (pass, stage, keywords the stage sees) once, then dedupe by content.
  std::vector<StageSource> stage_sources;
  // Every cache key starts with what a compile's output depends on besides its input: the tools, the
  // options, the stage and the entry point.
  // (A Hasher for local keys, a RemoteKeyHasher for remote keys: the same fields.)
  auto add_compile_options = [&](auto& hasher, Stage stage, const std::string& entry_point) -> auto& {
    return hasher.add(fingerprint).add(options.optimize ? 1 : 0).add(target_names).add(stage_name(stage)).add(entry_point);
  };
  auto source_key = [&](const StageSource& s) {
    Hasher key;
    return add_compile_options(key, s.stage, plan->pack.passes[s.pass].entry_points[static_cast<size_t>(s.stage)])
        .add(s.text)
        .finish();
  };
  // The compiler workers: preprocessing runs in them too, under their memory and time limits (a macro that
  // expands exponentially costs a worker, not kiln), and the compile stage reuses them.
  std::optional<WorkerPool> pool;
  auto worker_pool = [&]() -> WorkerPool& {
    if (!pool) {
      std::filesystem::path exe = options.worker_executable.empty() ? default_worker_executable() : options.worker_executable;
      pool.emplace(exe, parallelism(options), WorkerLimits{options.worker_timeout, options.worker_memory_limit_mb, options.frontend});
    }
    return *pool;
  };
  // Each pass's files as a Preprocess job carries them (the entry first), made once and shared by its jobs.
  std::vector<std::shared_ptr<const std::vector<IncludableFile>>> pass_files(plan->passes.size());
  auto files_of = [&](uint32_t pass) {
    if (!pass_files[pass]) {
      auto files = std::make_shared<std::vector<IncludableFile>>();
      for (const std::filesystem::path& path : plan->declarations[pass].files) {
        const SourceFile* file = plan->sources.find(path);
        if (!file) continue;
        IncludableFile served{display_path(path), file->text, file->pragma_once, {}};
        for (const auto& [name, target] : file->includes) served.includes.emplace(name, display_path(target));
        files->push_back(std::move(served));
      }
      pass_files[pass] = std::move(files);
    }
    return pass_files[pass];
  };
  auto preprocess_all = [&](const std::vector<size_t>& which) {
    if (which.empty()) return;
    std::vector<CompileJob> jobs(which.size());
    for (size_t w = 0; w < which.size(); ++w) {
      const StageSource& s = stage_sources[which[w]];
      jobs[w].id = which[w];
      jobs[w].kind = JobKind::Preprocess;
      jobs[w].stage = s.stage;
      jobs[w].files = files_of(s.pass);
      jobs[w].defines = s.defines;
    }
    worker_pool().run(jobs, [&](size_t j, WorkerOutcome outcome) {
      StageSource& s = stage_sources[which[j]];
      const std::string entry_name = display_path(plan->declarations[s.pass].entry);
      s.preprocessed = true;
      s.ok = false;
      if (outcome.kind == WorkerOutcome::Kind::Done && outcome.output.failed_step == "internal") {
        s.internal_error = "threw an exception (" +
                           (outcome.output.messages.empty() ? std::string("no message") : outcome.output.messages[0].text) + ")";
      } else if (outcome.kind == WorkerOutcome::Kind::Done) {
        s.ok = outcome.output.ok;
        s.text = std::move(outcome.output.preprocessed);
        s.messages = std::move(outcome.output.messages);
        s.files_read = std::move(outcome.output.files_read);
        if (s.ok) s.key = source_key(s);
      } else if (outcome.kind == WorkerOutcome::Kind::OutOfMemory) {
        s.messages = {{Severity::Error, entry_name, 0,
                       "preprocessing needed more than the compiler worker's " + std::to_string(options.worker_memory_limit_mb) +
                           " MiB (a macro that expands exponentially?)"}};
      } else if (outcome.kind == WorkerOutcome::Kind::TimedOut) {
        s.messages = {{Severity::Error, entry_name, 0,
                       "preprocessing took longer than the compiler worker's " +
                           std::to_string(options.worker_timeout.count() / 1000) + " s (a macro that expands exponentially?)"}};
      } else {
        s.internal_error = outcome.detail;  // the preprocessor crashed: a bug in it, not in the shader
      }
      std::vector<std::string>().swap(jobs[j].defines);
    });
  };
  // variant_binary_source[p][v][stage] -> index into stage_sources, or -1
  std::vector<std::vector<std::array<int, kStageCount>>> variant_source(plan->passes.size());
  {
    StageTimer timer(report, "preprocess");
    std::map<std::tuple<uint32_t, Stage, std::vector<std::string>>, size_t> index;
    for (uint32_t p = 0; p < plan->passes.size(); ++p) {
      const auto& variants = plan->expansions[p].variants;
      variant_source[p].resize(variants.size());
      for (size_t v = 0; v < variants.size(); ++v) {
        for (Stage s : kAllStages) {
          int& slot = variant_source[p][v][static_cast<size_t>(s)];
          slot = -1;
          if (plan->pack.passes[p].entry_points[static_cast<size_t>(s)].empty()) continue;
          ++report.funnel.stage_instances;
          auto defines = enabled_keywords(plan->passes[p].groups, variants[v], s);
          auto [it, inserted] = index.emplace(std::make_tuple(p, s, defines), stage_sources.size());
          if (inserted) stage_sources.push_back(StageSource{p, s, defines, v});
          slot = static_cast<int>(it->second);
        }
      }
    }
    // A stage source whose memo is in the cache, with every file it read unchanged, is not preprocessed:
    // its key comes from the memo, and its text is made only if the cache does not have its result. The
    // memo key covers the versions, options, stage, entry point, defines, working directory (names in
    // #line) and the list of every file the scan found (a new file could change what an #include finds).
    if (memos) {
      Hasher listing;
      std::error_code cwd_error;
      listing.add(std::filesystem::current_path(cwd_error).string());
      for (const auto& [path, file] : plan->sources.files) {
        listing.add(path.string());
        file_hashes[display_path(path)] = hash64(file.text);
      }
      const std::string files_listed = listing.finish().hex();
      for (StageSource& s : stage_sources) {
        Hasher memo;
        add_compile_options(memo.add("preprocess"), s.stage, plan->pack.passes[s.pass].entry_points[static_cast<size_t>(s.stage)])
            .add(display_path(plan->declarations[s.pass].entry))
            .add(files_listed);
        for (const std::string& define : s.defines) memo.add(define);
        s.memo = memo.finish();
        bool rejected = false;
        std::optional<PreprocessMemo> known = cache->load_memo(s.memo, [&](const PreprocessMemo& candidate) {
          return !candidate.files.empty() && std::all_of(candidate.files.begin(), candidate.files.end(), [&](const auto& file) {
                   auto it = file_hashes.find(file.first);
                   return it != file_hashes.end() && it->second == file.second;
                 });
        }, rejected);
        if (rejected) ++report.cache_rejected;
        if (!known) continue;
        s.ok = true;
        s.key = known->source_key;
        ++report.preprocess_memo_hits;
      }
    }
    std::vector<size_t> pending;
    for (size_t i = 0; i < stage_sources.size(); ++i)
      if (!stage_sources[i].key) pending.push_back(i);
    preprocess_all(pending);
    report.funnel.unique_preprocessed = stage_sources.size();
  }
  std::map<std::string, std::filesystem::path> by_name;
  for (const auto& [path, file] : plan->sources.files) by_name[display_path(path)] = path;
  auto located = [&](const FrontendMessage& m, const std::string& fallback) {
    SourceLocation at{m.path.empty() ? fallback : m.path, m.line, m.column};
    // glslang's preprocessor reads a directive's newline before it reports, so its errors name the next line.
    const bool about_directive = m.text.starts_with("'#") || m.text.starts_with("'preprocessor evaluation'");
    if (about_directive && at.line > 1 && !is_directive(line_of(plan->sources, by_name, at.path, at.line)) &&
        is_directive(line_of(plan->sources, by_name, at.path, at.line - 1)))
      --at.line;
    if (at.column == 0) at.column = guess_column(line_of(plan->sources, by_name, at.path, at.line), m.text);
    return at;
  };

  // Identical messages from many variants are reported once, naming the first variant and the count.
  // Ordered by compile index (not by which worker finished first) so that output is deterministic.
  struct Grouped {
    DiagId id;
    SourceLocation at;
    std::string text;
    std::vector<std::pair<size_t, std::string>> variants;  // compile index, description
  };
  std::vector<Grouped> grouped;
  std::map<std::tuple<int, std::string, int, std::string>, size_t> grouped_index;
  auto collect = [&](DiagId id, SourceLocation at, const std::string& text, const std::string& variant, size_t order) {
    auto key = std::make_tuple(static_cast<int>(id), at.path, at.line, text);
    auto [it, inserted] = grouped_index.emplace(key, grouped.size());
    if (inserted) grouped.push_back({id, std::move(at), text, {}});
    grouped[it->second].variants.emplace_back(order, variant);
  };

  // A stage source that did not preprocess: its first error only (after one, glslang's preprocessor stops,
  // and what it reports next, like "missing #endif" after an #error, cascades from it).
  auto preprocess_failed = [&](const StageSource& s, size_t order) {
    const std::string entry_name = display_path(plan->declarations[s.pass].entry);
    if (!s.internal_error.empty()) {
      report.internal_errors = true;
      sink.report(DiagId::InternalCompilerError, SourceLocation{entry_name, 0, 0},
                  "internal compiler error: the compiler worker " + s.internal_error + " while preprocessing " +
                      variant_description(*plan, s),
                  {"this is a bug in the compiler, not in your shader"});
      return;
    }
    auto first = std::find_if(s.messages.begin(), s.messages.end(),
                              [](const FrontendMessage& m) { return m.severity == Severity::Error; });
    if (first == s.messages.end())  // failed without saying why: still an error, never a silently missing variant
      collect(DiagId::PreprocessorError, SourceLocation{entry_name, 0, 0}, "preprocessing failed", variant_description(*plan, s), order);
    else
      collect(DiagId::PreprocessorError, located(*first, entry_name), first->text, variant_description(*plan, s), order);
  };

  std::vector<Binary> binaries;
  {
    StageTimer timer(report, "dedupe");
    std::map<Hash128, size_t> by_key;
    for (size_t i = 0; i < stage_sources.size(); ++i) {
      StageSource& s = stage_sources[i];
      if (!s.ok) {
        preprocess_failed(s, i);
        continue;
      }
      const std::string& entry_point = plan->pack.passes[s.pass].entry_points[static_cast<size_t>(s.stage)];
      const Hash128 key = *s.key;
      auto [it, inserted] = by_key.emplace(key, binaries.size());
      if (inserted) binaries.push_back(Binary{key, s.stage, entry_point, i, {}, nullptr});
      binaries[it->second].sources.push_back(i);
      s.binary = static_cast<int>(it->second);
    }
    report.funnel.unique_compiles = binaries.size();
  }

  // Stage 5-7: compile the cache misses in worker processes, in two halves. Each stage source's front end
  // (glslang) runs once; its module is hashed, and the back end (legalize, validate, optimize, validate,
  // reflect, cross-compile) runs once per distinct module, so stage sources that differ only in code their
  // entry point never reaches (a fragment keyword's branch in a file the vertex stage also includes) share
  // one. Both halves are cached: the back end's result under the module's key, and under the source's key
  // an alias to it with the front end's warnings.
  {
    std::optional<StageTimer> timer(std::in_place, report, "compile");
    std::vector<CompileJob> jobs;
    std::vector<size_t> job_subject;  // FrontEnd job -> binary, BackEnd job -> module
    std::vector<std::optional<Hash128>> module_of(binaries.size());  // for the funnel
    std::vector<size_t> misses;
    for (size_t b = 0; b < binaries.size(); ++b) {
      bool rejected = false;
      if (cache) {
        if (auto cached = cache->load(binaries[b].key, rejected, &module_of[b]))
          binaries[b].output = std::make_shared<const JobOutput>(std::move(*cached));
        if (rejected) ++report.cache_rejected;
        if (binaries[b].output) {
          ++report.cache_hits;
          continue;
        }
      }
      misses.push_back(b);
    }
    // Misses known only through a memo are preprocessed now: the workers need their text.
    std::vector<size_t> unpreprocessed;
    for (size_t b : misses)
      if (!stage_sources[binaries[b].source].preprocessed) unpreprocessed.push_back(binaries[b].source);
    preprocess_all(unpreprocessed);
    // Local misses the remote cache has are not compiled: its entries, verified, go into the local cache too.
    std::vector<std::optional<RemoteKey>> remote_key_of(binaries.size());
    size_t remote_hits = 0;
    if (remote && remote->usable()) {
      std::vector<size_t> asked;
      std::vector<RemoteKey> keys;
      for (size_t b : misses) {
        const StageSource& s = stage_sources[binaries[b].source];
        if (!s.ok) continue;
        RemoteKeyHasher key;
        remote->start_key(key, "source");
        remote_key_of[b] = add_compile_options(key, s.stage, binaries[b].entry_point).add(s.text).finish();
        asked.push_back(b);
        keys.push_back(*remote_key_of[b]);
      }
      std::vector<std::optional<RemoteFetched>> fetched = remote->fetch(keys);
      for (size_t i = 0; i < asked.size(); ++i) {
        if (!fetched[i]) continue;
        const size_t b = asked[i];
        RemoteFetched& hit = *fetched[i];
        if (cache) {
          cache->store(hit.module, hit.module_output);
          cache->store_alias(*stage_sources[binaries[b].source].key, hit.module, hit.front_messages);
        }
        hit.module_output.messages.insert(hit.module_output.messages.begin(), hit.front_messages.begin(), hit.front_messages.end());
        binaries[b].output = std::make_shared<const JobOutput>(std::move(hit.module_output));
        module_of[b] = hit.module;
        ++remote_hits;
      }
      remote->report_problems(sink);
    }
    for (size_t b : misses) {
      if (binaries[b].output) continue;  // from the remote cache
      const StageSource& s = stage_sources[binaries[b].source];
      if (!s.ok) {  // the memo said it preprocessed; it does not now (it cannot, with the same files)
        preprocess_failed(s, binaries[b].source);
        continue;
      }
      if (options.shard_count > 1 && s.key->low % options.shard_count != options.shard_index) {
        ++report.shard_skipped;  // another shard's
        continue;
      }
      binaries[b].key = *s.key;  // the text's own key, whatever a memo said
      CompileJob job;
      job.id = b;
      job.kind = JobKind::FrontEnd;
      job.stage = binaries[b].stage;
      job.entry_point = binaries[b].entry_point;
      job.source_name = display_path(plan->declarations[s.pass].entry);
      job.source = s.text;
      job.targets = targets;
      job.optimize = options.optimize;
      jobs.push_back(std::move(job));
      job_subject.push_back(b);
    }
    report.compiled = jobs.size();

    struct Module {
      Hash128 key;
      bool settled = false;                     // its back end has finished, or the cache had it
      std::shared_ptr<const JobOutput> output;  // when settled and good
      WorkerOutcome failure;                    // when settled and not good
      bool fresh = false;                       // compiled in this build: cached once the build is known good
      std::vector<size_t> waiting;              // binaries whose front end produced it, before it settled
      std::optional<RemoteKey> remote_key;      // when this build may upload it
    };
    std::vector<Module> modules;
    std::map<Hash128, size_t> module_by_key;
    std::vector<std::vector<FrontendMessage>> front_messages(binaries.size());
    std::vector<bool> front_end_ran(binaries.size(), false);
    size_t done = report.cache_hits + remote_hits;
    if (options.progress) options.progress(done, binaries.size(), report.cache_hits);

    // `module`: the front end's SPIR-V, when the worker died in the back end.
    auto fail = [&](size_t b, const WorkerOutcome& outcome, const std::vector<uint32_t>* module) {
      Binary& binary = binaries[b];
      const StageSource& s = stage_sources[binary.source];
      std::string variant = variant_description(*plan, s);
      const size_t order = stage_sources.size() + b;
      // An exception inside the worker is kiln's bug like a crash is: exit 2, never a user error.
      const bool threw = outcome.kind == WorkerOutcome::Kind::Done && outcome.output.failed_step == "internal";
      if (outcome.kind != WorkerOutcome::Kind::Done || threw) {
        const std::string detail =
            threw ? "threw an exception (" + (outcome.output.messages.empty() ? std::string("no message") : outcome.output.messages[0].text) + ")"
                  : outcome.detail;
        report.internal_errors = true;
        // A reproducer next to the outputs: the exact preprocessed source the worker was given, and for a
        // back-end death the module it was given too, with the SPIRV-Tools commands that replay the back end.
        std::filesystem::path dir = options.output_dir / "kiln-ice";
        std::filesystem::create_directories(dir, ec);
        const std::string base = plan->pack.passes[s.pass].name + "." + std::string(stage_name(s.stage)) + "." + slug(s.defines);
        std::filesystem::path repro = dir / (base + ".hlsl");
        std::string header = "// kiln internal compiler error: the compiler worker " + detail + "\n// " +
                             variant + ", entry point " + binary.entry_point + "\n// reproduce: glslangValidator -D -V -S " +
                             (s.stage == Stage::Vertex ? "vert" : "frag") + " -e " + binary.entry_point + " " +
                             repro.filename().string() + "\n";
        std::vector<std::string> notes{"reproducer written to " + repro.string()};
        if (module) {
          std::filesystem::path spv = dir / (base + ".spv");
          write_file_atomic(spv, std::string_view(reinterpret_cast<const char*>(module->data()), module->size() * 4));
          header += "// the front end succeeded; the worker died in the back end, given " + spv.filename().string() +
                    ":\n// spirv-opt --legalize-hlsl " + base + ".spv -o legal.spv && spirv-val --target-env vulkan1.1 "
                    "legal.spv && spirv-opt -O legal.spv -o opt.spv && spirv-cross opt.spv\n";
          notes.push_back("the front end's SPIR-V module (the back end's input) written to " + spv.string());
        }
        notes.push_back("this is a bug in the compiler, not in your shader");
        write_file_atomic(repro, header + s.text);
        sink.report(DiagId::InternalCompilerError, SourceLocation{display_path(plan->declarations[s.pass].entry), 0, 0},
                    "internal compiler error: the compiler worker " + detail + " while compiling " + variant, notes);
        return;
      }
      const std::string entry_name = display_path(plan->declarations[s.pass].entry);
      const std::string& step = outcome.output.failed_step;
      if (step == "entry-point") {
        SourceLocation at = locate_json_string(plan->pack.file.string(), plan->pack.text, binary.entry_point);
        collect(DiagId::MissingEntryPoint, at,
                "entry point '" + binary.entry_point + "' of the " + std::string(stage_name(s.stage)) +
                    " stage is not defined in '" + entry_name + "'",
                variant, order);
        return;
      }
      DiagId id = step == "frontend" ? DiagId::HlslError
                  : step == "reflect" ? DiagId::BlockTooLarge
                  : step.rfind("validate", 0) == 0 ? DiagId::SpirvInvalid
                  : step.rfind("cross", 0) == 0 ? DiagId::CrossCompileFailed
                  : DiagId::OptimizerFailed;
      // Only the first error: glslang's later ones cascade from it ("'declaration' : Expected").
      auto first = std::find_if(outcome.output.messages.begin(), outcome.output.messages.end(),
                                [](const FrontendMessage& m) { return m.severity == Severity::Error; });
      if (first != outcome.output.messages.end() && id == DiagId::BlockTooLarge) {
        collect(id, locate_declaration(*plan, s.pass, quoted_name(first->text), entry_name), first->text, variant, order);
      } else if (first != outcome.output.messages.end()) {
        std::string prefix = id == DiagId::HlslError ? "" : step + ": ";
        collect(id, located(*first, entry_name), prefix + first->text, variant, order);
      } else {
        collect(id, SourceLocation{entry_name, 0, 0}, step + " failed", variant, order);
      }
    };
    auto count_done = [&] {
      ++done;
      if (options.progress) options.progress(done, binaries.size(), report.cache_hits);
    };
    // A binary whose module has settled is done: it shares the module's output, or reports its failure.
    auto settle = [&](size_t b, const Module& module, const std::vector<uint32_t>& spirv) {
      if (module.output) binaries[b].output = module.output;
      else fail(b, module.failure, &spirv);
      count_done();
    };

    if (!jobs.empty()) {
      WorkerPool& workers = worker_pool();
      // A finished job's input (its source text or its module) is not read again: free it now, not when the
      // build ends (`= {}` would keep the capacity).
      auto release_input = [&jobs](size_t j) {
        std::string().swap(jobs[j].source);
        std::vector<uint32_t>().swap(jobs[j].spirv);
      };
      workers.run(jobs, [&](size_t j, WorkerOutcome outcome) {
        if (jobs[j].kind == JobKind::BackEnd) {
          Module& module = modules[job_subject[j]];
          module.settled = true;
          module.fresh = outcome.kind == WorkerOutcome::Kind::Done && outcome.output.ok;
          if (module.fresh) {
            if (outcome.output.full_legalization) ++report.full_legalizations;
            module.output = std::make_shared<const JobOutput>(std::move(outcome.output));
          } else {
            module.failure = std::move(outcome);
          }
          for (size_t b : module.waiting) settle(b, module, jobs[j].spirv);
          module.waiting = {};
          release_input(j);
          return;
        }
        release_input(j);
        const size_t b = job_subject[j];
        front_end_ran[b] = true;
        if (outcome.kind != WorkerOutcome::Kind::Done || !outcome.output.ok) {
          fail(b, outcome, nullptr);
          count_done();
          return;
        }
        const StageSource& s = stage_sources[binaries[b].source];
        for (const FrontendMessage& m : outcome.output.messages)
          if (m.severity == Severity::Warning)
            collect(DiagId::HlslWarning, located(m, ""), m.text, variant_description(*plan, s), stage_sources.size() + b);
        front_messages[b] = std::move(outcome.output.messages);
        const std::vector<uint32_t>& spirv = outcome.output.spirv;
        Hasher module_key;
        Hash128 key = add_compile_options(module_key, binaries[b].stage, binaries[b].entry_point)
                          .add(std::string_view(reinterpret_cast<const char*>(spirv.data()), spirv.size() * 4))
                          .finish();
        auto [it, inserted] = module_by_key.emplace(key, modules.size());
        module_of[b] = key;
        if (inserted) {
          Module module;
          module.key = key;
          if (remote && options.remote.upload) {
            RemoteKeyHasher remote_key;
            remote->start_key(remote_key, "module");
            module.remote_key = add_compile_options(remote_key, binaries[b].stage, binaries[b].entry_point)
                                    .add(std::string_view(reinterpret_cast<const char*>(spirv.data()), spirv.size() * 4))
                                    .finish();
          }
          bool rejected = false;
          if (cache) {
            if (auto cached = cache->load(key, rejected)) {
              module.settled = true;
              module.output = std::make_shared<const JobOutput>(std::move(*cached));
              ++report.back_end_hits;
            }
            if (rejected) ++report.cache_rejected;
          }
          if (!module.settled) {
            CompileJob back;
            back.id = modules.size();
            back.kind = JobKind::BackEnd;
            back.stage = jobs[j].stage;
            back.entry_point = jobs[j].entry_point;
            back.source_name = jobs[j].source_name;
            back.spirv = std::move(outcome.output.spirv);  // `spirv` is not read again on this path
            back.targets = jobs[j].targets;
            back.optimize = jobs[j].optimize;
            jobs.push_back(std::move(back));  // runs next, in whichever worker is free
            job_subject.push_back(modules.size());
            ++report.back_ends;
          }
          modules.push_back(std::move(module));
        }
        Module& module = modules[it->second];
        if (module.settled) settle(b, module, spirv);
        else module.waiting.push_back(b);
      });
      report.workers_started = workers.spawned();
    }
    // Distinct modules among the built binaries, whether compiled now or found through cache aliases.
    std::set<Hash128> distinct_modules;
    for (size_t b = 0; b < binaries.size(); ++b)
      if (binaries[b].output) distinct_modules.insert(module_of[b].value_or(binaries[b].key));
    report.funnel.unique_modules = distinct_modules.size();
    // A build with errors in the user's input leaves no cache entry behind. Internal compiler errors are
    // not the input's fault: the other variants' results are kept, so the next build only retries those.
    const bool user_errors = std::any_of(grouped.begin(), grouped.end(), [](const Grouped& g) {
      return diagnostic_info(g.id).severity == Severity::Error;
    });
    timer.reset();
    if (cache) report.cache_rejected += cache->unreadable_segments();
    if (cache && report.cache_rejected)
      sink.report(DiagId::CacheEntryRejected, SourceLocation{cache->directory().string(), 0, 0},
                  std::to_string(report.cache_rejected) + " cache entr" + (report.cache_rejected == 1 ? "y was" : "ies were") +
                      " corrupt, truncated or foreign: compiled again and rewritten",
                  {"nothing of them reached the outputs; if this repeats, check the disk or what else writes to the cache"});
    if (cache && !user_errors) {
      // Entries are encoded on every core (the workers are done by now), then written as one segment file.
      StageTimer store_timer(report, "cache store");
      const unsigned threads = parallelism(options);
      parallel_for(modules.size(), threads, [&](size_t m) {
        if (modules[m].fresh) cache->store(modules[m].key, *modules[m].output);
      });
      // A binary has an output only when its module's result is good (compiled now or already cached).
      parallel_for(binaries.size(), threads, [&](size_t b) {
        if (front_end_ran[b] && binaries[b].output) cache->store_alias(binaries[b].key, *module_of[b], front_messages[b]);
      });
      if (memos)
        parallel_for(stage_sources.size(), threads, [&](size_t i) {
          const StageSource& s = stage_sources[i];
          if (!s.preprocessed || !s.ok) return;
          PreprocessMemo memo{*s.key, {}};
          for (const std::string& name : s.files_read) {
            auto hash = file_hashes.find(name);
            if (hash == file_hashes.end()) return;  // not a file of the snapshot: no memo
            memo.files.emplace_back(name, hash->second);
          }
          cache->store_memo(s.memo, memo);
        });
      if (std::string error = cache->commit(); !error.empty())
        sink.report(DiagId::CacheUnwritable, SourceLocation{cache->directory().string(), 0, 0}, error,
                    {"the outputs are unaffected; the next build compiles these variants again"});
    }
    if (remote && options.remote.upload && !user_errors) {
      // What this build's front ends produced: each module's result (blobs first), then each source's alias.
      StageTimer upload_timer(report, "remote upload");
      std::vector<RemoteCache::ModuleUpload> uploads;
      std::map<Hash128, size_t> upload_of;
      for (const Module& m : modules)
        if (m.output && m.remote_key) {
          upload_of.emplace(m.key, uploads.size());
          uploads.push_back({*m.remote_key, m.output.get()});
        }
      std::vector<RemoteCache::AliasUpload> aliases;
      for (size_t b = 0; b < binaries.size(); ++b) {
        auto module = module_of[b] ? upload_of.find(*module_of[b]) : upload_of.end();
        if (front_end_ran[b] && binaries[b].output && remote_key_of[b] && module != upload_of.end())
          aliases.push_back({*remote_key_of[b], module->second, *module_of[b], &front_messages[b]});
      }
      remote->upload(uploads, aliases);
    }
    if (remote) {
      remote->report_problems(sink);
      report.remote = remote->report();
    }
  }
  for (Grouped& g : grouped) std::sort(g.variants.begin(), g.variants.end());
  std::sort(grouped.begin(), grouped.end(), [](const Grouped& a, const Grouped& b) { return a.variants[0].first < b.variants[0].first; });
  for (Grouped& g : grouped) {
    std::vector<std::string> notes{"in " + g.variants.front().second};
    if (g.variants.size() > 1) notes.push_back("and in " + std::to_string(g.variants.size() - 1) + " more variant(s)");
    if (g.id == DiagId::CrossCompileFailed && g.text.starts_with("cross-")) {  // "cross-gles: ..."
      const std::string target = g.text.substr(6, g.text.find_first_of(": ") - 6);
      notes.push_back("SPIRV-Cross cannot write this for the '" + target + "' target; if the pack does not ship it, remove \"" +
                      target + "\" from the pack's \"targets\" (or build with --targets)");
    }
    sink.report(g.id, g.at, g.text, notes);
  }
  if (sink.has_errors()) return finish();
  // A shard stops here: its share is in the caches (and uploaded); the merge build writes the pack.
  if (options.shard_count > 1) {
    report.ok = true;
    return finish();
  }

  // Stage 7 (second half): every variant and stage of a pass must agree on the resource layout.
  std::vector<json> pass_layouts(plan->passes.size());
  {
    StageTimer timer(report, "reflect");
    for (uint32_t p = 0; p < plan->passes.size(); ++p) {
      std::vector<LayoutSource> sources;
      std::set<int> seen;
      for (size_t i = 0; i < stage_sources.size(); ++i) {
        const StageSource& s = stage_sources[i];
        if (s.pass != p || !seen.insert(s.binary).second) continue;
        sources.push_back({variant_description(*plan, s), &binaries[static_cast<size_t>(s.binary)].output->reflection});
      }
      pass_layouts[p] = merge_pass_layout(plan->pack.passes[p].name, sources, plan->pack.passes[p].defined_at, sink);
    }
    if (sink.has_errors()) return finish();
  }

  // Stage 8: the pack. Binaries and blobs are numbered in (pass, variant, stage) order: same bytes for any -j.
  {
    StageTimer timer(report, "pack");
    ArchiveBuilder archive;
    std::map<size_t, size_t> binary_order;        // compile index -> manifest binary index
    std::map<Hash128, size_t> binary_by_output;   // identical outputs from different sources are stored once
    std::map<Hash128, size_t> reflection_by_hash;  // most binaries of a pass share one reflection
    json binaries_json = json::array();
    json reflections_json = json::array();
    json passes_json = json::array();
    for (uint32_t p = 0; p < plan->passes.size(); ++p) {
      const PassDefinition& def = plan->pack.passes[p];
      json stages = json::object();
      for (Stage s : kAllStages)
        if (!def.entry_points[static_cast<size_t>(s)].empty())
          stages[std::string(stage_name(s))] = def.entry_points[static_cast<size_t>(s)];
      json groups = json::array();
      for (const KeywordGroup& g : plan->passes[p].groups) groups.push_back(keyword_group_json(g));
      json variants = json::array();
      const auto& expansion = plan->expansions[p];
      for (size_t v = 0; v < expansion.variants.size(); ++v) {
        json stage_binaries = json::object();
        for (Stage s : kAllStages) {
          int source = variant_source[p][v][static_cast<size_t>(s)];
          if (source < 0) continue;
          size_t b = static_cast<size_t>(stage_sources[static_cast<size_t>(source)].binary);
          auto known = binary_order.find(b);
          if (known == binary_order.end()) {
            const JobOutput& out = *binaries[b].output;
            const Hash128 spirv = out.blobs.at(Target::Spirv).key;
            Hash128 output_key = Hasher()
                                     .add(stage_name(binaries[b].stage))
                                     .add(binaries[b].entry_point)
                                     .add(spirv.low)
                                     .add(spirv.high)
                                     .finish();
            auto [by_output, fresh] = binary_by_output.emplace(output_key, binaries_json.size());
            if (fresh) {
              json blobs = json::object();
              for (const auto& [target, blob] : out.blobs) blobs[std::string(target_name(target))] = archive.add(blob);
              std::string reflection_text = out.reflection.dump();
              auto [reflection, new_reflection] = reflection_by_hash.emplace(hash128(reflection_text), reflections_json.size());
              if (new_reflection) reflections_json.push_back(out.reflection);
              binaries_json.push_back({{"stage", stage_name(binaries[b].stage)},
                                       {"entry", binaries[b].entry_point},
                                       {"blobs", blobs},
                                       {"reflection", reflection->second}});
            }
            known = binary_order.emplace(b, by_output->second).first;
          }
          stage_binaries[std::string(stage_name(s))] = known->second;
        }
        variants.push_back({{"keywords", enabled_keywords(plan->passes[p].groups, expansion.variants[v])},
                            {"binaries", stage_binaries}});
      }
      passes_json.push_back({{"name", def.name},
                             {"stages", stages},
                             {"keyword_groups", groups},
                             {"layout", pass_layouts[p]},
                             {"variants", variants}});
    }
    json target_list_json = json::array();
    for (Target t : targets) target_list_json.push_back(target_name(t));
    report.funnel.unique_binaries = binaries_json.size();
    const Funnel& f = report.funnel;
    json manifest{{"format", kManifestFormat},
                  {"format_version", kPackFormatVersion},
                  {"name", plan->pack.name},
                  {"kiln_version", kKilnVersion},
                  {"tools", {{"frontend", frontend->name() + " " + frontend->version()},
                             {"spirv_tools", spirv_tools_version()},
                             {"spirv_cross", spirv_cross_version()}}},
                  {"options", {{"optimize", options.optimize}, {"targets", target_list_json},
                               {"spirv_env", "vulkan1.1"}, {"glsl_version", 450}, {"gles_version", 310},
                               {"msl_version", "2.1"}, {"gl_clip_space_fixup", true}}},
                  {"inputs_hash", inputs_hash},
                  {"funnel", {{"declared", f.declared}, {"valid", f.valid}, {"kept", f.kept},
                              {"stage_instances", f.stage_instances}, {"unique_preprocessed", f.unique_preprocessed},
                              {"unique_compiles", f.unique_compiles}, {"unique_modules", f.unique_modules},
                              {"unique_binaries", f.unique_binaries}}},
                  {"constraints", constraints_json(plan->pack)},
                  {"materials", materials_json(plan->pack)},
                  {"scene_features", plan->pack.scene_features_json.empty() ? json::object()
                                                                           : json::parse(plan->pack.scene_features_json)},
                  {"passes", passes_json},
                  {"binaries", binaries_json},
                  {"reflections", reflections_json}};
    WrittenPack written = write_pack(options.output_dir, plan->pack.name, archive, manifest);
    if (!written.error.empty()) {
      sink.report(DiagId::OutputUnwritable, SourceLocation{options.output_dir.string(), 0, 0}, written.error);
      return finish();
    }
    // Last: the stamp that lets the next build with the same inputs skip everything.
    write_file_atomic(stamp_path(options.output_dir, plan->pack.name),
                      stamp_text(options.output_dir, plan->pack.name, written.archive_file, inputs_hash));
    if (pack_key && options.remote.upload) remote->upload_pack(*pack_key, options.output_dir, plan->pack.name, written.archive_file);
  }

  // Dumps for debugging (--emit), named <pass>/<stage>/<keywords>.<ext> under <output>/emit.
  if (!options.emit.empty()) {
    StageTimer timer(report, "emit");
    std::filesystem::path root = options.output_dir / "emit";
    auto put = [&](const std::filesystem::path& path, const std::string& bytes) {
      std::filesystem::create_directories(path.parent_path(), ec);
      if (std::string error = write_file_atomic(path, bytes); !error.empty())
        sink.report(DiagId::OutputUnwritable, SourceLocation{path.string(), 0, 0}, error);
    };
    if (options.emit.count("variants")) {
      json listing = json::array();
      for (uint32_t p = 0; p < plan->passes.size(); ++p)
        for (const Variant& v : plan->expansions[p].variants)
          listing.push_back({{"pass", plan->pack.passes[p].name}, {"keywords", enabled_keywords(plan->passes[p].groups, v)}});
      put(root / "variants.json", listing.dump(2) + "\n");
    }
    for (const StageSource& s : stage_sources) {
      std::filesystem::path base = root / plan->pack.passes[s.pass].name / std::string(stage_name(s.stage)) / slug(s.defines);
      const JobOutput& out = *binaries[static_cast<size_t>(s.binary)].output;
      if (options.emit.count("preprocessed")) put(base.string() + ".hlsl", s.text);
      auto put_blob = [&](const char* stage, Target target, const char* extension) {
        if (options.emit.count(stage) && out.blobs.count(target)) put(base.string() + extension, unpack_blob(out.blobs.at(target)));
      };
      if (options.emit.count("spvasm")) put(base.string() + ".spvasm", disassemble_spirv(unpack_spirv(out.blobs.at(Target::Spirv))));
      put_blob("glsl", Target::Glsl, ".glsl");
      put_blob("glsl", Target::Gles, ".es.glsl");
      put_blob("msl", Target::Msl, ".metal");
      if (options.emit.count("reflection")) put(base.string() + ".reflection.json", out.reflection.dump(2) + "\n");
    }
  }
  write_depfile();
  if (remote) {
    remote->report_problems(sink);
    report.remote = remote->report();
  }
  report.ok = !sink.has_errors();
  return finish();
}

}  // namespace kiln
