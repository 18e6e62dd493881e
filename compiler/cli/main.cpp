// kiln command-line interface: parses arguments, calls the library, prints. Nothing else lives here.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <map>
#include <optional>
#include <string_view>
#include <sstream>

#include "allocator.hpp"
#include "progress_line.hpp"
#include "common/files.hpp"
#include "cross/targets.hpp"
#include "definition/definition.hpp"
#include "frontend/frontend.hpp"
#include "kiln/build.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "lint/lint.hpp"
#include "optimize/spirv_tools.hpp"
#include "tools/pack_tools.hpp"

namespace {

using nlohmann::json;

// Diagnostics in colour (--color: auto, always, never). Auto: when stderr is a terminal and TERM is set and not
// "dumb", unless NO_COLOR is set to anything (no-color.org); always and never win over NO_COLOR.
bool g_colour = false;

bool colour_for(const std::string& mode) {
  if (mode == "always") return true;
  if (mode == "never") return false;
  const char* no_colour = std::getenv("NO_COLOR");
  const char* term = std::getenv("TERM");
  return !(no_colour && *no_colour) && ::isatty(2) && term && *term && std::string_view(term) != "dumb";
}

void print_diagnostics_as_they_come(kiln::DiagnosticSink& sink) {
  sink.set_listener([](const kiln::Diagnostic& d) { std::cerr << kiln::format_diagnostic(d, g_colour); });
}

// "120", "1", "0.5": a default in seconds as --help states it.
std::string seconds_text(std::chrono::milliseconds duration) {
  std::ostringstream out;
  out << std::chrono::duration<double>(duration).count();
  return out.str();
}

std::string format_ms(double ms) {
  char text[32];
  if (ms >= 1000) std::snprintf(text, sizeof text, "%.2f s", ms / 1000);
  else std::snprintf(text, sizeof text, "%.1f ms", ms);
  return text;
}

void print_summary(const kiln::BuildReport& r, std::ostream& out, const std::string& shard) {
  if (!shard.empty()) {
    out << "kiln: shard " << shard << " of " << r.manifest.string() << ": compiled " << r.compiled << ", "
        << r.shard_skipped << " left to the other shards (no pack written: a build without --shard writes it)\n";
    if (r.remote.configured)
      out << "  remote cache: hits " << r.remote.hits << ", uploads " << r.remote.uploads << " (" << r.remote.blobs_uploaded
          << " blobs), " << r.remote.bytes_up << " bytes up, errors " << r.remote.errors << "\n";
    return;
  }
  const kiln::Funnel& f = r.funnel;
  const bool built = !r.up_to_date && !r.remote.pack_fetched;  // else nothing was compiled or looked up
  out << "kiln: " << (r.up_to_date ? "up to date: " : r.remote.pack_fetched ? "fetched from the remote cache: " : "wrote ")
      << r.manifest.string() << "\n";
  out << "  variants: " << (f.declared_saturated ? "more than " : "") << f.declared << " declared -> " << f.valid
      << " valid -> " << f.kept << " after stripping";
  if (built)
    out << " -> " << f.stage_instances << " stage variants -> " << f.unique_preprocessed << " unique per stage -> "
        << f.unique_compiles << " compiles -> " << f.unique_modules << " modules -> " << f.unique_binaries
        << " unique binaries";
  out << "\n";
  if (built)
    out << "  compiled " << r.compiled << " (back ends " << r.back_ends << ", full legalizations "
        << r.full_legalizations << ", cached back ends " << r.back_end_hits
        << "), cache hits " << r.cache_hits << " (not preprocessed " << r.preprocess_memo_hits << ")"
        << (r.cache_rejected ? ", rejected cache entries " + std::to_string(r.cache_rejected) : std::string())
        << ", workers " << r.workers_started << "\n";
  if (!r.up_to_date && r.remote.configured && r.remote.pack_fetched)
    out << "  remote cache: the finished pack of these inputs, " << r.remote.bytes_down << " bytes down\n";
  else if (built && r.remote.configured)
    out << "  remote cache: hits " << r.remote.hits << ", misses " << r.remote.misses << ", uploads " << r.remote.uploads
        << " (" << r.remote.blobs_uploaded << " blobs), " << r.remote.bytes_down << " bytes down, " << r.remote.bytes_up
        << " bytes up, errors " << r.remote.errors << (r.remote.switched_off ? " (switched off)" : "") << "\n";
  if (built && !r.strip_report.empty()) {
    out << "  strip report:\n";
    for (const kiln::StripLine& line : r.strip_report)
      out << "    " << line.pass << ": " << line.what << ": " << line.count
          << (line.reason.empty() ? "" : " (" + line.reason + ")") << "\n";
  }
  out << "  time:";
  for (size_t i = 0; i < r.timings.size(); ++i)
    out << (i ? ", " : " ") << r.timings[i].stage << " " << format_ms(r.timings[i].milliseconds);
  out << "\n";
}

// `kiln build --summary-json FILE`: what the summary says, for CI dashboards; written whether the build
// succeeded or not (README.md lists the fields; they are only ever added).
json summary_json(const kiln::BuildReport& r, const kiln::DiagnosticSink& sink, int exit_code, const kiln::BuildOptions& options) {
  const kiln::Funnel& f = r.funnel;
  json timings = json::array();
  for (const kiln::StageTiming& t : r.timings)
    timings.push_back({{"stage", t.stage}, {"milliseconds", t.milliseconds}, {"start_ms", t.start_ms}, {"end_ms", t.end_ms}});
  json workers = json::array();
  for (const kiln::WorkerTimeline& w : r.worker_timeline)
    workers.push_back({{"spawned_ms", w.spawned_ms}, {"first_compile_ms", w.first_compile_ms >= 0 ? json(w.first_compile_ms) : json()},
                       {"idle_before_first_compile_ms", w.first_compile_ms >= 0 ? json(w.idle_before_first_compile_ms) : json()},
                       {"last_done_ms", w.last_done_ms}, {"preprocess_busy_ms", w.preprocess_busy_ms},
                       {"compile_busy_ms", w.compile_busy_ms}, {"idle_ms", w.idle_ms}, {"jobs", w.jobs}});
  json strip = json::array();
  for (const kiln::StripLine& line : r.strip_report)
    strip.push_back({{"pass", line.pass}, {"what", line.what}, {"count", line.count}, {"reason", line.reason}});
  json out{{"ok", r.ok},
           {"exit_code", exit_code},
           {"errors", sink.error_count()},
           {"warnings", sink.warning_count()},
           {"internal_errors", r.internal_errors},
           {"up_to_date", r.up_to_date},
           {"manifest", r.ok ? json(r.manifest.string()) : json()},
           {"funnel", {{"declared", f.declared}, {"declared_saturated", f.declared_saturated}, {"valid", f.valid},
                       {"kept", f.kept}, {"stage_instances", f.stage_instances},
                       {"unique_preprocessed", f.unique_preprocessed}, {"unique_compiles", f.unique_compiles},
                       {"unique_modules", f.unique_modules}, {"unique_binaries", f.unique_binaries}}},
           {"compiled", r.compiled},
           {"back_ends", r.back_ends},
           {"back_end_cache_hits", r.back_end_hits},
           {"full_legalizations", r.full_legalizations},
           {"cache_hits", r.cache_hits},
           {"preprocess_memo_hits", r.preprocess_memo_hits},
           {"cache_rejected", r.cache_rejected},
           {"workers", r.workers_started},
           {"remote", {{"configured", r.remote.configured}, {"switched_off", r.remote.switched_off},
                       {"pack_fetched", r.remote.pack_fetched}, {"hits", r.remote.hits}, {"misses", r.remote.misses},
                       {"uploads", r.remote.uploads}, {"blobs_uploaded", r.remote.blobs_uploaded},
                       {"bytes_down", r.remote.bytes_down}, {"bytes_up", r.remote.bytes_up}, {"errors", r.remote.errors}}},
           {"timings", timings},
           {"worker_timeline", workers},
           {"strip_report", strip}};
  if (options.shard_count > 1)
    out["shard"] = {{"index", options.shard_index}, {"count", options.shard_count}, {"left_to_other_shards", r.shard_skipped}};
  return out;
}

// Rendering and golden tests: verbs of kiln-verify, found like kiln-worker ($KILN_VERIFY, next to kiln, then
// ../libexec/kiln, then the build tree).
const std::pair<const char*, const char*> kVerifyVerbs[] = {
    {"render", "Render a scene with one Forward variant of a pack (lavapipe or llvmpipe GL; runs kiln-verify)"},
    {"test", "Render every Forward variant and compare it with its CPU-reference golden (runs kiln-verify)"},
};

int run_verify(int argc, char** argv) {
  std::vector<std::filesystem::path> candidates;
  if (const char* env = std::getenv("KILN_VERIFY"); env && *env) candidates.emplace_back(env);
  std::error_code ec;
  if (auto self = std::filesystem::read_symlink("/proc/self/exe", ec); !ec) {
    candidates.push_back(self.parent_path() / "kiln-verify");
    candidates.push_back(self.parent_path().parent_path() / "libexec" / "kiln" / "kiln-verify");
  }
#ifdef KILN_BUILD_VERIFY_PATH
  candidates.emplace_back(KILN_BUILD_VERIFY_PATH);
#endif
  for (const std::filesystem::path& candidate : candidates) {
    if (::access(candidate.c_str(), X_OK) != 0) continue;
    std::vector<char*> args(argv, argv + argc);
    std::string program = candidate.string();
    args[0] = program.data();
    args.push_back(nullptr);
    ::execv(program.c_str(), args.data());
    std::cerr << "kiln: error: cannot run " << program << ": " << std::strerror(errno) << "\n";
    return 1;
  }
  std::cerr << "kiln: error: 'kiln " << argv[1] << "' runs kiln-verify, which this installation does not have "
            << "(configure kiln with -DKILN_BUILD_VERIFY=ON, or set KILN_VERIFY to its path)\n";
  return 1;
}

int run_build(kiln::BuildOptions options, bool no_cache, const std::string& cache_dir, bool quiet, const std::string& summary_file) {
  kiln::DiagnosticSink sink;
  if (!no_cache) options.cache_dir = cache_dir.empty() ? std::filesystem::path(".kiln-cache") : std::filesystem::path(cache_dir);
  std::optional<kiln::cli::ProgressLine> progress;
  if (!quiet && kiln::cli::is_interactive_terminal(2)) progress.emplace(stderr, kiln::cli::terminal_columns(2));
  if (progress) {
    sink.set_listener([&progress](const kiln::Diagnostic& d) {
      progress->print_above([&] { std::cerr << kiln::format_diagnostic(d, g_colour) << std::flush; });
    });
    options.progress = [&progress](size_t done, size_t total, size_t hits) { progress->update(done, total, hits); };
  } else {
    print_diagnostics_as_they_come(sink);
  }
  kiln::BuildReport report = kiln::build_pack(options, sink);
  if (progress) progress->finish();
  const std::string shard = options.shard_count > 1 ? std::to_string(options.shard_index) + "/" + std::to_string(options.shard_count) : "";
  if (report.ok && !quiet) print_summary(report, std::cout, shard);
  int code = kiln::exit_code(sink, report.internal_errors);
  int errors = sink.error_count();
  if (!summary_file.empty())
    if (std::string error = kiln::write_file_atomic(summary_file, summary_json(report, sink, code, options).dump(2) + "\n");
        !error.empty()) {
      std::cerr << "kiln: error: --summary-json: " << error << "\n";
      code = std::max(code, 1);
      ++errors;  // counted: "kiln: 0 error(s)" under an error was a contradiction
    }
  if (code != 0)
    std::cerr << "kiln: " << errors << " error(s)"
              << (report.internal_errors ? ", including internal compiler errors" : "") << "\n";
  return code;
}

int run_list(kiln::BuildOptions options, bool as_json) {
  kiln::DiagnosticSink sink;
  print_diagnostics_as_they_come(sink);
  auto listing = kiln::list_variants(options, sink);
  if (!listing) return kiln::exit_code(sink, false);
  if (as_json) {
    json out = json::array();
    for (const auto& v : listing->variants) {
      json stages = json::object();
      for (const auto& [stage, kw] : v.stage_keywords) stages[stage] = kw;
      out.push_back({{"pass", v.pass}, {"keywords", v.keywords}, {"stages", stages}});
    }
    // What each pass is built with: its binding options (DXC's spelling; "" is the default) and defines.
    json passes = json::array();
    for (const auto& settings : listing->pass_settings) {
      json defines = json::object();
      for (const auto& define : settings.defines) defines[define.name] = define.value;
      passes.push_back({{"pass", settings.pass}, {"bindings", settings.bindings.canonical()}, {"defines", defines}});
    }
    std::cout << json{{"pack", listing->pack}, {"passes", passes}, {"variants", out}}.dump(2) << "\n";
  } else {
    for (const auto& v : listing->variants) {
      std::cout << v.pass << ": " << kiln::join_keywords(v.keywords);
      for (const auto& [stage, kw] : v.stage_keywords) std::cout << " | " << stage << ": " << kiln::join_keywords(kw);
      std::cout << "\n";
    }
    std::cout << listing->variants.size() << " variants (" << listing->funnel.declared << " declared, "
              << listing->funnel.valid << " valid)\n";
  }
  return 0;
}

int run_inspect(const std::string& pack_dir, bool as_json, const std::string& extract) {
  try {
    kiln::PackReader pack = kiln::PackReader::open(pack_dir);
    const kiln::Manifest& manifest = pack.manifest();
    if (!extract.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(extract, ec);
      if (ec || !std::filesystem::is_directory(extract)) {
        std::cerr << extract << ": error[K1601]: cannot create the --extract directory"
                  << (ec ? ": " + ec.message() : std::string(": a file of that name is in the way")) << "\n";
        return 1;
      }
      for (size_t b = 0; b < manifest.binaries.size(); ++b) {
        const kiln::ManifestBinary& binary = manifest.binaries[b];
        for (const auto& [target, id] : binary.blobs) {
          std::string name = "binary" + std::to_string(b) + "." + std::string(kiln::stage_name(binary.stage)) +
                             std::string(kiln::target_extension(target));
          if (auto error = kiln::write_file_atomic(std::filesystem::path(extract) / name, std::string(pack.blob(id)));
              !error.empty()) {
            std::cerr << "kiln: error: " << error << "\n";
            return 1;
          }
        }
      }
    }
    if (as_json) {
      json out{{"name", pack.name()}, {"archive", manifest.archive.file}, {"tools", manifest.tools}, {"passes", json::array()}};
      for (const kiln::ManifestPass& pass : manifest.passes) {
        json variants = json::array();
        for (const kiln::ManifestVariant& variant : pass.variants) variants.push_back(variant.keywords);
        json entry{{"name", pass.name}, {"variants", variants}, {"layout", pass.layout}};
        // The bindings chosen (docs/bindings.md): the options, defines and resulting layout of the pass.
        if (!pass.bindings.empty()) entry["bindings"] = pass.bindings;
        if (!pass.defines.empty()) entry["defines"] = pass.defines;
        out["passes"].push_back(std::move(entry));
      }
      std::cout << out.dump(2) << "\n";
    } else {
      std::cout << "pack '" << pack.name() << "', format " << manifest.format_version << ", " << manifest.binaries.size()
                << " binaries, " << manifest.archive.blobs << " blobs, " << manifest.archive.size << " bytes in "
                << manifest.archive.file << "\n";
      for (const kiln::ManifestPass& pass : manifest.passes) {
        std::cout << "  pass " << pass.name << ": " << pass.variants.size() << " variants\n";
        if (!pass.bindings.empty()) std::cout << "    bindings: " << pass.bindings << "\n";
        if (!pass.defines.empty()) std::cout << "    defines: " << json(pass.defines).dump() << "\n";
        for (const kiln::Resource& r : pass.layout.resources)
          std::cout << "    set " << r.set << " binding " << r.binding << ": " << r.name << " ("
                    << kiln::resource_kind_name(r.kind) << ")\n";
        for (const kiln::ManifestVariant& variant : pass.variants)
          std::cout << "    [" << kiln::join_keywords(variant.keywords) << "]\n";
      }
    }
    return 0;
  } catch (const kiln::PackError& error) {
    std::cerr << (error.file().empty() ? pack_dir : error.file()) << ": error: " << error.what() << "\n";
    return 1;
  }
}

int run_check_scene(const std::string& pack_dir, const std::string& scene, bool as_json) {
  kiln::DiagnosticSink sink;
  print_diagnostics_as_they_come(sink);
  try {
    kiln::PackReader pack = kiln::PackReader::open(pack_dir);
    auto result = kiln::check_scene(pack, scene, sink);
    if (!result) return 1;
    if (as_json) {
      json missing = json::array();
      for (const auto& m : result->missing) missing.push_back({{"pass", m.pass}, {"keywords", m.keywords}});
      std::cout << json{{"requested", result->requested}, {"missing", missing}}.dump(2) << "\n";
    } else {
      for (const auto& m : result->missing)
        std::cout << scene << ": error: pass '" << m.pass << "' variant [" << kiln::join_keywords(m.keywords)
                  << "] can be requested by the scene but is not in pack '" << pack.name() << "'\n";
      std::cout << "kiln check-scene: " << result->requested << " combinations the scene can request, "
                << result->missing.size() << " missing\n";
    }
    return result->missing.empty() ? 0 : 1;
  } catch (const kiln::PackError& error) {
    std::cerr << (error.file().empty() ? pack_dir : error.file()) << ": error: " << error.what() << "\n";
    return 1;
  }
}

int run_diff_packs(const std::string& a, const std::string& b, bool as_json) {
  try {
    kiln::PackReader first = kiln::PackReader::open(a), second = kiln::PackReader::open(b);
    kiln::PackDiff diff = kiln::diff_packs(first, second);
    if (as_json) {
      auto list = [](const std::vector<kiln::KeywordCombination>& items) {
        json out = json::array();
        for (const auto& i : items) out.push_back({{"pass", i.pass}, {"keywords", i.keywords}});
        return out;
      };
      std::cout << json{{"added", list(diff.added)}, {"removed", list(diff.removed)}, {"changed", list(diff.changed)}}.dump(2)
                << "\n";
    } else {
      for (const auto& i : diff.removed) std::cout << "- " << i.pass << " [" << kiln::join_keywords(i.keywords) << "]\n";
      for (const auto& i : diff.added) std::cout << "+ " << i.pass << " [" << kiln::join_keywords(i.keywords) << "]\n";
      for (const auto& i : diff.changed) std::cout << "~ " << i.pass << " [" << kiln::join_keywords(i.keywords) << "]\n";
      std::cout << diff.added.size() << " added, " << diff.removed.size() << " removed, " << diff.changed.size()
                << " changed\n";
    }
    return 0;
  } catch (const kiln::PackError& error) {
    std::cerr << (error.file().empty() ? "kiln diff-packs" : error.file()) << ": error: " << error.what() << "\n";
    return 1;
  }
}

}  // namespace

// kiln's version and every tool it was built with, as its cache keys and manifests name them (what a bug report needs).
std::string version_text() {
  std::string text = std::string("kiln ") + kiln::kKilnVersion + "\n";
  for (const std::string& name : kiln::frontend_names())
    if (auto frontend = kiln::make_frontend(name)) text += "front end: " + frontend->name() + " " + frontend->version() + "\n";
  text += "SPIRV-Tools: " + kiln::spirv_tools_version() + "\n";
  text += "optimizer recipe: kiln (default; -O without " +
          std::to_string(kiln::optimizer_pass_names(kiln::OptimizerRecipe::Stock).size() -
                         kiln::optimizer_pass_names(kiln::OptimizerRecipe::Kiln).size()) +
          " of its " + std::to_string(kiln::optimizer_pass_names(kiln::OptimizerRecipe::Stock).size()) +
          " passes), O with --optimize=O\n";
  text += "SPIRV-Cross: " + kiln::spirv_cross_version() + "\n";
  return text + "allocator: " + kiln::allocator_description();
}

int main(int argc, char** argv) {
  for (const auto& [verb, description] : kVerifyVerbs)
    if (argc > 1 && std::strcmp(argv[1], verb) == 0) return run_verify(argc, argv);
  CLI::App app{"kiln: shader permutation compiler (HLSL -> SPIR-V, GLSL, GLSL ES, MSL variant packs)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", version_text());

  kiln::BuildOptions options;
  std::string pack_file, output, cache_dir, depfile, summary_file, colour_mode = "auto";
  app.add_option("--color", colour_mode, "Colour diagnostics: auto (on a terminal, unless NO_COLOR is set), always, never")
      ->check(CLI::IsMember({"auto", "always", "never"}));
  app.fallthrough();  // --color also after the verb
  std::vector<std::string> scenes, emit;
  bool no_cache = false, quiet = false, as_json = false;
  unsigned jobs = 0;
  double timeout_s = std::chrono::duration<double>(kiln::defaults::kWorkerTimeout).count();

  // Binding model and defines (docs/bindings.md): DXC's spellings; build, list and lint take them alike.
  std::vector<std::string> define_texts;
  std::map<char, std::vector<std::pair<std::string, std::string>>> shift_texts;
  std::pair<std::string, std::string> globals_text;
  bool auto_bind = false, no_auto_bind = false, combined = false, separate = false;
  auto add_binding_options = [&](CLI::App* cmd) {
    cmd->add_option("-D,--define", define_texts, "Preprocessor define NAME or NAME=VALUE (repeatable; wins over the pack's)");
    for (char c : std::string("btsu"))
      cmd->add_option(std::string("--fvk-") + c + "-shift", shift_texts[c],
                      std::string("N SPACE: shift the bindings of ") + c + " registers in SPACE (a number or 'all') by N (repeatable)");
    cmd->add_option("--fvk-bind-globals", globals_text, "N M: the implicit $Global uniform block at binding N, set M");
    cmd->add_flag("--auto-bind", auto_bind, "Bind resources that declare no register automatically (the default)");
    cmd->add_flag("--no-auto-bind", no_auto_bind, "Do not bind resources that declare no register automatically");
    cmd->add_flag("--combined-image-samplers", combined, "A texture and a sampler at one register number become one combined binding");
    cmd->add_flag("--separate-image-samplers", separate, "Keep textures and samplers apart (the default)");
  };
  // False (with K1014 reported) when an argument is malformed.
  auto read_binding_options = [&](kiln::BuildOptions& into) {
    kiln::DiagnosticSink sink;
    print_diagnostics_as_they_come(sink);
    bool ok = true;
    if (auto defines = kiln::parse_command_line_defines(define_texts, sink)) into.defines = *defines;
    else ok = false;
    for (auto& [letter, list] : shift_texts)
      for (auto& [shift, space] : list)
        ok = kiln::parse_command_line_shift(*kiln::parse_register_class(std::string(1, letter)), shift, space, into.bindings, sink) && ok;
    if (!globals_text.first.empty())
      ok = kiln::parse_command_line_globals(globals_text.first, globals_text.second, into.bindings, sink) && ok;
    if (auto_bind || no_auto_bind) into.bindings.auto_bind = !no_auto_bind;
    if (combined || separate) into.bindings.combined_image_samplers = !separate;
    return ok;
  };

  auto add_scene = [&](CLI::App* cmd) {
    cmd->add_option("--scene", scenes, "Scene profile (JSON); keep only variants some scene can request")->check(CLI::ExistingFile);
  };

  CLI::App* build = app.add_subcommand("build", "Build a variant pack from a pack definition");
  build->add_option("pack", pack_file, "Pack definition (variants/*.pack.json)")->required();
  build->add_option("-o,--output", output, "Output directory for <name>.manifest.json and its archive")->required();
  add_scene(build);
  add_binding_options(build);
  build->add_option("-j,--jobs", jobs, "Compiler worker processes (default, or 0: one per core)");
  auto* cache_opt = build->add_option("--cache", cache_dir, "Cache directory (default: ./.kiln-cache)");
  build->add_flag("--no-cache", no_cache, "Do not read or write the cache")->excludes(cache_opt);
  uint64_t cache_max_mb = kiln::BuildOptions{}.cache_max_mb;
  build->add_option("--cache-max-mb", cache_max_mb,
                    "Cache size limit: least recently used entries go first (default: " + std::to_string(kiln::defaults::kCacheMaxMb) + ")")
      ->check(CLI::PositiveNumber);
  build->add_option("--emit", emit, "Dump a stage: variants, preprocessed, spvasm, glsl, msl, reflection (repeatable)")
      ->check(CLI::IsMember(kiln::emit_stage_names()))
      ->delimiter(',');
  build->add_option("--depfile", depfile, "Write a Makefile-style depfile listing every input read");
  std::vector<std::string> target_names, known_targets;
  for (const kiln::TargetName& target : kiln::kTargetNames) known_targets.emplace_back(target.name);
  build->add_option("--targets", target_names, "Override the pack's targets: " + kiln::target_name_list() + " (comma-separated)")
      ->check(CLI::IsMember(known_targets))
      ->delimiter(',');
  build->add_option("--frontend", options.frontend, "HLSL front end (default: glslang)")
      ->check(CLI::IsMember(kiln::frontend_names()));
  std::string recipe_name(kiln::optimizer_recipe_name(kiln::OptimizerRecipe::Kiln));
  build->add_option("--optimize", recipe_name,
                    "Optimizer recipe: kiln (default: -O without the passes kiln's legalization already did; the same "
                    "SPIR-V once IDs are compacted) or O (SPIRV-Tools' -O as spirv-opt runs it)")
      ->check(CLI::IsMember({std::string(kiln::optimizer_recipe_name(kiln::OptimizerRecipe::Kiln)),
                             std::string(kiln::optimizer_recipe_name(kiln::OptimizerRecipe::Stock))}));
  build->add_option("--worker-timeout", timeout_s, "Seconds one compile job may take before it is an internal error (default: " +
                                                     seconds_text(kiln::defaults::kWorkerTimeout) + ")");
  build->add_flag("-q,--quiet", quiet, "Print only diagnostics");
  build->add_option("--summary-json", summary_file, "Also write the build summary as JSON (funnel, cache and remote counts, "
                                                    "timings, diagnostics), whether the build succeeds or not");
  // The remote cache (docs/remote-cache.md). Credentials come from the environment or netrc, never from arguments.
  kiln::RemoteCacheOptions& remote = options.remote;
  double remote_connect_s = remote.connect_timeout.count() / 1000.0, remote_timeout_s = remote.operation_timeout.count() / 1000.0;
  build->add_option("--remote", remote.url, "Remote cache base URL, Bazel HTTP cache protocol (default: $KILN_REMOTE)");
  build->add_flag("--remote-upload", remote.upload, "Upload what this build compiles (read-only otherwise)");
  build->add_flag("--remote-required", remote.required, "Remote cache problems are errors, not warnings");
  build->add_option("--remote-instance", remote.instance, "Path prefix under the remote URL (instance name)");
  build->add_option("--remote-namespace", remote.key_namespace, "Mixed into every remote key: keeps caches apart on one server");
  build->add_option("--remote-connect-timeout", remote_connect_s,
                    "Seconds to connect to the remote cache (default: " + seconds_text(kiln::defaults::kRemoteConnectTimeout) + ")")
      ->check(CLI::PositiveNumber);
  build->add_option("--remote-timeout", remote_timeout_s,
                    "Seconds one remote request may take (default: " + seconds_text(kiln::defaults::kRemoteTimeout) + ")")
      ->check(CLI::PositiveNumber);
  std::string shard_text;
  build->add_option("--shard", shard_text, "I/N: compile only share I of N of the compile jobs, upload them, write no pack "
                                           "(needs --remote); auto: from Slurm's, GitLab's or a Kubernetes Indexed Job's "
                                           "environment");
  build->add_option("--remote-transfers", remote.parallel_transfers,
                    "Remote requests in flight, one connection each (default: " + std::to_string(kiln::defaults::kRemoteParallelTransfers) + ")")
      ->check(CLI::Range(1u, 64u));

  CLI::App* list = app.add_subcommand("list", "List every variant a pack would contain, with the keywords each stage sees");
  list->add_option("pack", pack_file, "Pack definition")->required();
  add_scene(list);
  add_binding_options(list);
  list->add_flag("--json", as_json, "Print JSON");

  std::string pack_dir, extract;
  CLI::App* inspect = app.add_subcommand("inspect", "Show a built pack; optionally extract its blobs");
  inspect->add_option("pack_dir", pack_dir, "Directory holding a pack (or its manifest)")->required();
  inspect->add_flag("--json", as_json, "Print JSON");
  inspect->add_option("--extract", extract, "Write each blob as a file (.spv, .glsl, .es.glsl, .metal)");

  bool werror = false;
  std::vector<std::string> lint_inputs, lint_include_dirs;
  std::string format = "text", lint_output, sarif_root;
  CLI::App* lint = app.add_subcommand("lint", "Lint a pack definition (every rule) or HLSL files (source rules); exit 1 on errors");
  // No CLI11 existence check: a missing input is a finding in the chosen format (an empty SARIF file breaks
  // a CI upload step with a confusing message).
  lint->add_option("inputs", lint_inputs, "A pack definition (.json), or HLSL files")->required();
  auto* lint_cache_opt = lint->add_option("--cache", cache_dir, "Cache directory for pack lint (default: $XDG_CACHE_HOME/kiln or ~/.cache/kiln)");
  lint->add_flag("--no-cache", no_cache, "Do not read or write the cache")->excludes(lint_cache_opt);
  add_scene(lint);
  add_binding_options(lint);
  lint->add_option("-I,--include-dir", lint_include_dirs, "Include root for the files' #include (file mode; repeatable)");
  lint->add_option("--format", format, "Output: text, json or sarif")->check(CLI::IsMember({"text", "json", "sarif"}));
  lint->add_option("-o,--output", lint_output, "Write the report to this file (only when lint ran: never an empty or partial file)");
  lint->add_option("--sarif-root", sarif_root, "SARIF URIs are relative to this directory (default: the git work tree, else the current directory)");
  lint->add_flag("--werror", werror, "Treat warnings as errors");

  std::string scene_file, other_dir;
  CLI::App* check = app.add_subcommand("check-scene", "Report every variant a scene can request that a built pack lacks");
  check->add_option("pack_dir", pack_dir, "Directory holding a pack (or its manifest)")->required();
  check->add_option("scene", scene_file, "Scene profile (JSON)")->required()->check(CLI::ExistingFile);
  check->add_flag("--json", as_json, "Print JSON");

  CLI::App* diff = app.add_subcommand("diff-packs", "Show the variants added, removed or changed between two packs");
  diff->add_option("a", pack_dir, "The old pack")->required();
  diff->add_option("b", other_dir, "The new pack")->required();
  diff->add_flag("--json", as_json, "Print JSON");

  // Rendering and golden tests live in kiln-verify (verify/), which links Vulkan, EGL, PNG and OpenEXR; kiln does not.
  // These entries only list them in --help: main() hands both verbs to kiln-verify before parsing.
  for (const auto& [verb, description] : kVerifyVerbs) app.add_subcommand(verb, description)->prefix_command();

  app.failure_message([](const CLI::App*, const CLI::Error& error) {
    return std::string("kiln: error: ") + error.what() + "\nRun with --help for more information.\n";
  });
  std::vector<std::string> verbs;
  for (const CLI::App* verb : app.get_subcommands({})) verbs.push_back(verb->get_name());
  if (argc > 1 && argv[1][0] != '-' && std::find(verbs.begin(), verbs.end(), argv[1]) == verbs.end()) {
    auto suggestion = kiln::closest_match(argv[1], verbs);
    std::cerr << "kiln: error: unknown command '" << argv[1] << "'"
              << (suggestion ? "; did you mean '" + *suggestion + "'?" : std::string()) << "\nRun with --help for more information.\n";
    return 1;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    // --help and --version end here with 0; any other argument error is the user's: exit code 1, not CLI11's 100+.
    return app.exit(error) == 0 ? 0 : 1;
  }
  g_colour = colour_for(colour_mode);
  if (*check) return run_check_scene(pack_dir, scene_file, as_json);
  if (*diff) return run_diff_packs(pack_dir, other_dir, as_json);

  options.pack_file = pack_file;
  for (const auto& s : scenes) options.scene_files.push_back(s);
  options.jobs = jobs;
  options.worker_timeout = std::chrono::milliseconds(static_cast<long>(timeout_s * 1000));
  if (!depfile.empty()) options.depfile = depfile;
  options.emit.insert(emit.begin(), emit.end());
  for (const auto& name : target_names) options.targets.push_back(*kiln::parse_target(name));
  if (!read_binding_options(options)) return 1;

  if (*build) {
    options.output_dir = output;
    options.optimizer_recipe = *kiln::parse_optimizer_recipe(recipe_name);
    // The remote's URL, token and CA file may come from the environment (KILN_REMOTE_TOKEN is never printed).
    auto environment = [](const char* name) { const char* value = std::getenv(name); return value ? std::string(value) : std::string(); };
    if (remote.url.empty()) remote.url = environment("KILN_REMOTE");
    remote.bearer_token = environment("KILN_REMOTE_TOKEN");
    remote.token_file = environment("KILN_REMOTE_TOKEN_FILE");
    remote.ca_file = environment("KILN_REMOTE_CA_FILE");
    remote.connect_timeout = std::chrono::milliseconds(static_cast<long>(remote_connect_s * 1000));
    remote.operation_timeout = std::chrono::milliseconds(static_cast<long>(remote_timeout_s * 1000));
    if (!shard_text.empty()) {
      auto process_environment = [](const char* name) { return std::getenv(name); };
      if (std::string error = kiln::parse_shard_option(shard_text, process_environment, options.shard_index, options.shard_count);
          !error.empty()) {
        std::cerr << "kiln: error: " << error << "\n";
        return 1;
      }
      if (remote.url.empty()) {
        std::cerr << "kiln: error: --shard needs a remote cache (--remote URL or KILN_REMOTE): the merge build reads the shards' work there\n";
        return 1;
      }
      remote.upload = true;  // a shard's work is for the merge
    }
    options.cache_max_mb = cache_max_mb;
    return run_build(options, no_cache, cache_dir, quiet, summary_file);
  }
  if (*list) return run_list(options, as_json);
  if (*inspect) return run_inspect(pack_dir, as_json, extract);
  if (*lint) {
    kiln::LintReport report;
    if (lint_inputs.size() == 1 && lint_inputs[0].ends_with(".json")) {
      // The pack is built into a scratch directory under $TMPDIR, else /tmp, else /var/tmp (as gcc falls back).
      std::error_code ec;
      std::string temp;
      std::vector<std::filesystem::path> places;
      if (const char* tmpdir = std::getenv("TMPDIR"); tmpdir && *tmpdir) places.emplace_back(tmpdir);
      places.insert(places.end(), {"/tmp", "/var/tmp"});
      for (const std::filesystem::path& place : places) {
        std::string candidate = (place / "kiln-lint-XXXXXX").string();
        if (::mkdtemp(candidate.data())) {
          temp = candidate;
          break;
        }
      }
      if (temp.empty()) {
        const char* tmpdir = std::getenv("TMPDIR");
        std::cerr << "kiln lint: error: cannot create a scratch directory under '" << (tmpdir && *tmpdir ? tmpdir : "(TMPDIR unset)")
                  << "', /tmp or /var/tmp" << (lint_output.empty() ? "" : "; '" + lint_output + "' was not written") << "\n";
        return 2;
      }
      options.pack_file = lint_inputs[0];
      options.output_dir = temp;
      if (!no_cache) options.cache_dir = cache_dir.empty() ? kiln::user_cache_directory() : std::filesystem::path(cache_dir);
      report = kiln::lint_pack(options);
      // A finding that names a file in the scratch directory (an internal compiler error's reproducer) keeps it.
      const bool referenced = std::any_of(report.findings.begin(), report.findings.end(), [&](const kiln::LintFinding& f) {
        return std::any_of(f.notes.begin(), f.notes.end(), [&](const std::string& note) { return note.find(temp) != std::string::npos; });
      });
      if (!referenced) std::filesystem::remove_all(temp, ec);
    } else {
      std::vector<std::filesystem::path> files(lint_inputs.begin(), lint_inputs.end());
      report = kiln::lint_files(files, std::vector<std::filesystem::path>(lint_include_dirs.begin(), lint_include_dirs.end()),
                                options.defines);
    }
    std::string text;
    if (format == "json") text = kiln::format_lint_json(report);
    else if (format == "sarif") text = kiln::format_lint_sarif(report, {sarif_root.empty() ? kiln::default_sarif_root(std::filesystem::current_path()) : std::filesystem::path(sarif_root)});
    else text = kiln::format_lint_text(report);
    if (!lint_output.empty()) {
      if (std::string error = kiln::write_file_atomic(lint_output, text); !error.empty()) {
        std::cerr << "kiln lint: error: " << error << "\n";
        return 2;
      }
    } else {
      (format == "text" ? std::cerr : std::cout) << text;
    }
    if (format == "text")
      std::cerr << "kiln lint: " << report.errors() << " error(s), " << report.warnings() << " warning(s)\n";
    return report.errors() > 0 || (werror && report.warnings() > 0) ? 1 : 0;
  }
  return 0;
}
