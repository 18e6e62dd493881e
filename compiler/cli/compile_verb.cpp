// kiln compile: one HLSL file for one stage, as a shader author first writes it with glslc or DXC
// (`glslc -fshader-stage=frag -fentry-point=main x.hlsl -o x.spv`, `dxc -T ps_6_0 -E main x.hlsl -Fo x.spv`).
// It is a one-pass build (the same front end, binding model, checks and diagnostics as `kiln build`) into a
// scratch directory, of which the chosen stage's code for the chosen target is written to -o (or stdout).
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>

#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "kiln/files.hpp"
#include "kiln/pack_reader.hpp"

namespace kiln::cli {
namespace {

using nlohmann::json;

// The stage by kiln's name or glslc's (-fshader-stage=frag) and glslangValidator's (-S frag).
std::optional<Stage> stage_from(const std::string& text) {
  for (const StageName& name : kStageNames)
    if (name.name == text || name.short_name == text) return name.stage;
  return std::nullopt;
}

// The target by --target, else by the output's extension (a row's extension or other extensions in kiln/targets.def,
// the longest that matches: .es.glsl before .glsl), else SPIR-V.
std::optional<Target> target_for(const std::string& flag, const std::string& output) {
  if (!flag.empty()) return parse_target(flag);
  std::optional<Target> best;
  size_t best_length = 0;
  auto consider = [&](Target target, std::string_view extension) {
    if (!extension.empty() && extension.size() > best_length && output.ends_with(extension)) {
      best = target;
      best_length = extension.size();
    }
  };
  for (const TargetName& t : kTargetNames) {
    consider(t.target, t.extension);
    std::string_view others = t.other_extensions;
    while (!others.empty()) {
      const size_t space = others.find(' ');
      consider(t.target, others.substr(0, space));
      others = space == std::string_view::npos ? std::string_view() : others.substr(space + 1);
    }
  }
  return best.value_or(Target::Spirv);
}

// ".spv, .glsl or .vert/.frag/..., .es.glsl, .metal": each target's extensions, for --help.
std::string extension_list() {
  std::string list;
  for (const TargetName& t : kTargetNames) {
    list += (list.empty() ? "" : ", ") + std::string(t.extension);
    if (!t.other_extensions.empty()) {
      std::string others(t.other_extensions);
      std::replace(others.begin(), others.end(), ' ', '/');
      list += " or " + others;
    }
  }
  return list;
}

class CompileVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("compile", "Compile one HLSL file for one stage, as glslc and DXC do (no pack)");
    verb->add_option("file", file_, "HLSL source")->required();
    verb->add_option("-S,--stage", stage_text_,
                     "Stage: vertex, fragment, compute, geometry, hull, domain (or glslc's vert, frag, comp, geom, tesc, tese)")
        ->required();
    verb->add_option("-E,--entry", entry_, "Entry point (default: main)");
    verb->add_option("-o,--output", output_, "Output file, or - for standard output")->required();
    verb->add_option("--target", target_text_,
                     target_name_list() + " (default: by the output's extension: " + extension_list() + "; else spirv)");
    verb->add_option("-I,--include-dir", include_dirs_, "Include root (repeatable; the file's own directory is one)");
    plan_.add_to(verb, /*scenes=*/false);
    verb->add_option("-O", optimize_, "Optimization: s (the default: kiln's recipe) or 0 (none: the legalized front-end code)")
        ->check(CLI::IsMember({"s", "0"}));
    verb->add_flag("-g", debug_,
                   "Debug information: the HLSL source (preprocessed, with its #line markers), line numbers and "
                   "names, as glslangValidator -g writes them; implies -O0");
    verb->add_option("--depfile", depfile_, "Write a Makefile-style depfile: the output depends on every file read");
    verb->add_flag("--werror", werror_, "Treat warnings as errors");
    return verb;
  }

  int run() override {
    const std::optional<Stage> stage = stage_from(stage_text_);
    const std::optional<Target> target = target_for(target_text_, output_);
    if (!stage || !target) {
      std::cerr << "kiln: error: " << (!stage ? "unknown stage '" + stage_text_ + "'" : "unknown target '" + target_text_ + "' (expected " + target_name_list() + ")")
                << "\n";
      return 1;
    }
    BuildOptions options;
    if (!plan_.apply(options)) return 1;
    const std::filesystem::path scratch = make_scratch("kiln-compile-");
    if (scratch.empty()) {
      std::cerr << "kiln: error[K1601]: cannot create a scratch directory under $TMPDIR, /tmp or /var/tmp\n";
      return exit_status(ExitClass::Environment);
    }
    // The one-pass pack: absolute paths, so that the scratch directory is no include root of the user's.
    std::error_code ec;
    json include_dirs = json::array();
    for (const std::string& dir : include_dirs_) include_dirs.push_back(std::filesystem::absolute(dir, ec).string());
    json pack{{"name", "compile"},
              {"include_dirs", include_dirs},
              {"targets", json::array({std::string(target_name(*target))})},
              {"passes", json::array({{{"name", "main"},
                                       {"source", std::filesystem::absolute(file_, ec).string()},
                                       {"stages", {{std::string(stage_name(*stage)), entry_}}}}})}};
    const std::filesystem::path pack_file = scratch / "compile.pack.json";
    if (Result<void> written = write_output_file(pack_file, pack.dump(2) + "\n"); !written) {
      std::cerr << "kiln: error[K1601]: " << written.error().message << "\n";
      std::filesystem::remove_all(scratch, ec);
      return exit_status(ExitClass::Environment);
    }
    options.pack_file = pack_file;
    options.output_dir = scratch / "out";
    options.optimize = optimize_ != "0" && !debug_;
    options.debug_info = debug_;
    // What the build says about the scratch pack definition is about the command line.
    DiagnosticSink sink;
    sink.set_listener([&pack_file](const Diagnostic& d) {
      Diagnostic shown = d;
      if (shown.location.path == pack_file.string() || shown.location.path == display_path(pack_file)) {
        shown.location = SourceLocation{"<command line>", 0, 0};
        shown.source_line.reset();
      }
      std::cerr << format_diagnostic(shown, colour());
    });
    const BuildReport report = build_pack(options, sink);
    int code = exit_code(sink, report.internal_errors);
    if (code == 0) code = write_output(report, *stage, *target, options.defines);
    if (code == 0 && werror_ && sink.warning_count() > 0) {
      std::cerr << "kiln: " << sink.warning_count() << " warning(s), errors with --werror\n";
      code = 1;
    }
    if (code == 0 && !depfile_.empty()) {
      std::vector<std::filesystem::path> read;
      for (const std::filesystem::path& dependency : report.dependencies)
        if (dependency != pack_file) read.push_back(dependency);
      if (!write_depfile(depfile_, output_ == "-" ? std::filesystem::path("-") : std::filesystem::path(output_), read, sink))
        code = exit_code(sink);
    }
    // An internal error's reproducer, which a diagnostic names, stays.
    if (!report.internal_errors) std::filesystem::remove_all(scratch, ec);
    return code;
  }

 private:
  // The stage's code for the target, of the variant the -D keywords select, to -o or stdout.
  int write_output(const BuildReport& report, Stage stage, Target target, const std::vector<Define>& defines) {
    try {
      PackReader pack = PackReader::open(report.manifest);
      std::vector<std::string> keywords;
      for (const Define& define : defines) keywords.push_back(define.name);
      const SelectedVariant variant = pack.select("main", keywords);
      const StageView* view = variant.stage(stage_name(stage));
      const std::string_view code = view ? view->code(target) : std::string_view();
      if (code.empty()) {
        std::cerr << "kiln: error: the build wrote no " << target_name(target) << " for the " << stage_name(stage) << " stage\n";
        return 2;
      }
      if (output_ == "-") {
        std::cout.write(code.data(), static_cast<std::streamsize>(code.size()));
        std::cout.flush();
        return std::cout ? 0 : exit_status(ExitClass::Environment);
      }
      if (Result<void> written = write_output_file(output_, code); !written) {
        std::cerr << output_ << ": error[K1601]: " << written.error().message << "\n";
        return exit_status(ExitClass::Environment);
      }
      return 0;
    } catch (const PackError& error) {
      using Code = PackError::Code;
      const Code code = error.code();
      if (code == Code::MissingKeyword || code == Code::ConflictingKeywords || code == Code::Stripped) {
        // The -D keywords name no variant (a keyword group without one of its keywords, two of one group): the
        // command line's fault, as a glslc user expects of a -D.
        Diagnostic diagnostic;
        diagnostic.id = DiagId::InvalidCommandLineOption;
        diagnostic.location.path = "<command line>";
        diagnostic.message = std::string("-D: the keywords select no variant: ") + error.what();
        std::cerr << format_diagnostic(diagnostic, colour());
        return exit_status(ExitClass::Input);
      }
      std::cerr << "kiln: internal error: the scratch pack cannot be read: " << error.what() << "\n";
      return 2;
    }
  }

  std::string file_, stage_text_, entry_ = "main", output_, target_text_, depfile_, optimize_ = "s";
  std::vector<std::string> include_dirs_;
  PlanArguments plan_;
  bool werror_ = false;
  bool debug_ = false;
};

}  // namespace

std::unique_ptr<Verb> make_compile_verb() { return std::make_unique<CompileVerb>(); }

}  // namespace kiln::cli
