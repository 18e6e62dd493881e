// SPDX-License-Identifier: Apache-2.0
// kiln compile: one HLSL file for one stage, as a shader author first writes it with glslc or DXC
// (`glslc -fshader-stage=frag -fentry-point=main x.hlsl -o x.spv`, `dxc -T ps_6_0 -E main x.hlsl -Fo x.spv`).
// It is a one-pass build (the same front end, binding model, checks and diagnostics as `kiln build`) into a
// scratch directory, of which the chosen stage's code for the chosen target is written to -o (or stdout).
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <iterator>
#include <regex>

#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "kiln/files.hpp"
#include "kiln/pack_reader.hpp"

namespace kiln::cli {
namespace {

using nlohmann::json;

// Other names of a stage that users type by habit: DXC's profile prefixes and "pixel", glslc's -fshader-stage names.
struct StageAlias {
  std::string_view name;
  Stage stage;
};
constexpr StageAlias kStageAliases[] = {
    {"pixel", Stage::Fragment},  {"ps", Stage::Fragment}, {"vs", Stage::Vertex},          {"cs", Stage::Compute},
    {"gs", Stage::Geometry},     {"hs", Stage::Hull},     {"tesscontrol", Stage::Hull}, {"ds", Stage::Domain},
    {"tesseval", Stage::Domain},
};
// Stages kiln cannot build, by the names users give them: said so, rather than "unknown".
constexpr std::string_view kMeshStageNames[] = {"mesh", "ms", "task", "amplification", "as"};
constexpr std::string_view kNoMeshStages =
    "glslang 12, kiln's HLSL front end, has no mesh or amplification shaders (DXC -T ms_6_5/as_6_5 builds them)";

// The stage by kiln's name, glslangValidator's (-S frag) or another name users type by habit (pixel, ps).
std::optional<Stage> stage_from(const std::string& text) {
  for (const StageName& name : kStageNames)
    if (name.name == text || name.short_name == text) return name.stage;
  for (const StageAlias& alias : kStageAliases)
    if (alias.name == text) return alias.stage;
  return std::nullopt;
}

// The message for a stage name kiln does not build.
std::string unknown_stage(const std::string& text) {
  std::string names;
  for (const StageName& name : kStageNames) names += (names.empty() ? "" : ", ") + std::string(name.name);
  if (std::find(std::begin(kMeshStageNames), std::end(kMeshStageNames), text) != std::end(kMeshStageNames))
    return "-S '" + text + "': " + std::string(kNoMeshStages);
  return "-S '" + text + "' is no stage (expected " + names + ", or vert, frag, comp, geom, tesc, tese, pixel, ps, vs, cs, gs, hs, ds)";
}

// One command-line error, located at the command line.
int command_line_error(const std::string& message) {
  Diagnostic diagnostic;
  diagnostic.id = DiagId::InvalidCommandLineOption;
  diagnostic.location.path = "<command line>";
  diagnostic.message = message;
  std::cerr << format_diagnostic(diagnostic, colour());
  return exit_status(ExitClass::Input);
}

// The spellings glslc, DXC and glslangValidator users type by habit, each with kiln's. A spelling that means exactly
// what kiln's does is rewritten into it before parsing; one that does not is refused with kiln's in the hint.
enum class Takes {
  Nothing,  // -spirv
  Joined,   // its value after '=': -fentry-point=main
  Next,     // its value in the next argument: -T ps_6_0 (DXC's also joined: -Tps_6_0)
  JoinedOrNext,  // either: glslc's --target-env=vulkan1.1, glslangValidator's --target-env vulkan1.1
};
enum class Reading {
  Rename,             // the spelling becomes kiln's, its value (if any) following
  Profile,            // DXC's -T: the stage from the profile
  HlslOnly,           // glslc's -x: the source language, which must be HLSL
  DepfileBesideOutput,  // glslc's -MD: the depfile is -MF's, else the output's name with .d
  OptimizeUnlessValued,  // glslc's -O: kiln's -O when no level follows (kiln's own -O s, -O 0 stay)
  TargetEnvironment,     // --target-env, -fspv-target-env: an environment that loads kiln's modules, else refused
  HlslVersion,           // DXC's -HV: a language version glslang's HLSL reads, else refused
};
struct Habit {
  std::string_view spelling;  // as the other tool spells it
  std::string_view tool;
  Takes takes;
  Reading reading;
  std::string_view kiln;     // kiln's spelling, words separated by spaces; empty: nothing
  std::string_view refused;  // empty: accepted; else why it is not kiln's option, before "use 'kiln'"
};
constexpr Habit kHabits[] = {
    {"-fshader-stage", "glslc", Takes::Joined, Reading::Rename, "-S", ""},
    {"-fentry-point", "glslc", Takes::Joined, Reading::Rename, "-E", ""},
    {"-e", "glslangValidator", Takes::Next, Reading::Rename, "-E", ""},
    {"-T", "DXC", Takes::Next, Reading::Profile, "-S", ""},
    {"-Fo", "DXC", Takes::Next, Reading::Rename, "-o", ""},
    {"-spirv", "DXC", Takes::Nothing, Reading::Rename, "--target spirv", ""},
    {"-x", "glslc", Takes::Next, Reading::HlslOnly, "", ""},
    {"-Werror", "glslc", Takes::Nothing, Reading::Rename, "--werror", ""},
    {"-WX", "DXC", Takes::Nothing, Reading::Rename, "--werror", ""},
    {"-MD", "glslc", Takes::Nothing, Reading::DepfileBesideOutput, "", ""},
    {"-MF", "glslc", Takes::Next, Reading::Rename, "--depfile", ""},
    {"-M", "glslc", Takes::Nothing, Reading::Rename, "--depfile FILE", "it writes the dependencies instead of compiling; kiln compile writes them beside the output"},
    {"-MM", "glslc", Takes::Nothing, Reading::Rename, "--depfile FILE", "it writes the dependencies instead of compiling; kiln compile writes them beside the output"},
    {"-fvk-b-shift", "DXC", Takes::Nothing, Reading::Rename, "--fvk-b-shift", ""},
    {"-fvk-t-shift", "DXC", Takes::Nothing, Reading::Rename, "--fvk-t-shift", ""},
    {"-fvk-s-shift", "DXC", Takes::Nothing, Reading::Rename, "--fvk-s-shift", ""},
    {"-fvk-u-shift", "DXC", Takes::Nothing, Reading::Rename, "--fvk-u-shift", ""},
    {"-fvk-bind-globals", "DXC", Takes::Nothing, Reading::Rename, "--fvk-bind-globals", ""},
    // glslc's -O and DXC's -O1..-O3 run SPIRV-Tools' performance recipe, whose modules kiln's recipe makes.
    {"-O", "glslc", Takes::Nothing, Reading::OptimizeUnlessValued, "-O s", ""},
    {"-O1", "DXC", Takes::Nothing, Reading::Rename, "-O s", ""},
    {"-O2", "DXC", Takes::Nothing, Reading::Rename, "-O s", ""},
    {"-O3", "DXC", Takes::Nothing, Reading::Rename, "-O s", ""},
    {"-Od", "DXC", Takes::Nothing, Reading::Rename, "-O 0", ""},
    {"-Zi", "DXC", Takes::Nothing, Reading::Rename, "-g", "kiln's -g also turns the optimizer off, as -Zi -Od does"},
    {"--target-env", "glslc", Takes::JoinedOrNext, Reading::TargetEnvironment, "", ""},
    {"-fspv-target-env", "DXC", Takes::Joined, Reading::TargetEnvironment, "", ""},
    {"-HV", "DXC", Takes::Next, Reading::HlslVersion, "", ""},
    // kiln always compiles with 16-bit types on (half and min16float are 16-bit floats), as DXC does with it.
    {"-enable-16bit-types", "DXC", Takes::Nothing, Reading::Rename, "", ""},
    {"-fvk-use-dx-layout", "DXC", Takes::Nothing, Reading::Rename, "",
     "kiln lays out constant buffers by glslang's Vulkan rules (an array's elements, and the member after an array, "
     "start on 16 bytes), not by DirectX's packing: state the offsets that must match D3D's with packoffset or "
     "[[vk::offset(N)]] (docs/bindings.md)"},
};

// The environments that load kiln's modules (SPIR-V 1.3 for Vulkan 1.1: the manifest's spirv_env); glslc and DXC
// write newer SPIR-V for the later ones, which kiln's module needs no feature of.
constexpr std::string_view kLoadingEnvironments[] = {"vulkan1.1", "vulkan1.2", "vulkan1.3"};

// glslc's, glslangValidator's or DXC's target environment, or why kiln cannot honour it.
Result<void> check_target_environment(std::string_view spelling, const std::string& environment) {
  if (std::find(std::begin(kLoadingEnvironments), std::end(kLoadingEnvironments), environment) != std::end(kLoadingEnvironments))
    return {};
  const std::string what = std::string(spelling) + " '" + environment + "'";
  if (environment.starts_with("opengl"))
    return failure(what + ": kiln's modules are for Vulkan 1.1; for OpenGL, use '--target glsl' (GLSL 4.50 made from the same module)");
  return failure(what + ": kiln's modules are SPIR-V 1.3 for Vulkan 1.1 (the manifest's spirv_env, vulkan1.1), which only "
                 "vulkan1.1, vulkan1.2 and vulkan1.3 load, and kiln builds for no other environment: use one of those, or nothing");
}

// DXC's HLSL language versions that glslang's HLSL, with kiln's rewrites, reads as DXC does: 2018, and of 2021
// select, and, or (templates, operator overloading and bit fields are errors that name the construct either way).
constexpr std::string_view kHlslVersions[] = {"2016", "2017", "2018", "2021"};

// DXC's profile (ps_6_0) as kiln's stage, or why it is none.
Result<std::string> stage_of_profile(const std::string& profile) {
  const size_t underscore = profile.find('_');
  const std::string kind = profile.substr(0, underscore);
  const std::string model = underscore == std::string::npos ? "" : profile.substr(underscore + 1);
  const bool model_6 = model.size() >= 3 && model.starts_with("6_") &&
                       model.find_first_not_of("0123456789", 2) == std::string::npos;
  if (kind == "lib")
    return failure("-T '" + profile + "' is a library profile, every entry point of the file at once; kiln compile builds one "
                 "stage: use '-S STAGE -E ENTRY' once for each entry point (or a pack, kiln build)");
  if (kind == "ms" || kind == "as") return failure("-T '" + profile + "': " + std::string(kNoMeshStages));
  const bool known = std::any_of(std::begin(kStageAliases), std::end(kStageAliases),
                                 [&](const StageAlias& alias) { return alias.name == kind && kind.size() == 2; });
  if (!known || !model_6)
    return failure("-T '" + profile + "' is no DXC profile kiln reads (expected vs, ps, cs, gs, hs or ds, then _6_0 to _6_8): "
                 "use '-S STAGE'");
  return std::string(kind);  // a stage alias; the shader model changes nothing glslang builds
}

// "-S", "frag" from "-S frag": kiln's spelling as arguments.
std::vector<std::string> words_of(std::string_view spelling) {
  std::vector<std::string> words;
  while (!spelling.empty()) {
    const size_t space = spelling.find(' ');
    words.emplace_back(spelling.substr(0, space));
    spelling = space == std::string_view::npos ? std::string_view() : spelling.substr(space + 1);
  }
  return words;
}

// The build speaks of its one-pass pack ("in pass 'main' fragment stage, keywords [FOG]", "in 1 variant", "in the
// pack definition"); kiln compile's user wrote a file, a stage and -D keywords, and reads of those.
std::string in_file_and_stage_words(std::string text, const std::string& file) {
  auto replace_all = [&text](const std::string& from, const std::string& to) {
    for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) text.replace(at, from.size(), to);
  };
  auto with_defines = [](const std::string& keywords) {  // "A B" -> " with -D A -D B"; "<none>" -> ""
    if (keywords == "<none>") return std::string();
    std::string out;
    for (const std::string& k : words_of(keywords)) out += (out.empty() ? " with -D " : " -D ") + k;
    return out;
  };
  static const std::regex variant_note(R"(^in pass 'main' ([a-z]+) stage, keywords \[([^\]]*)\])");
  static const std::regex more_variants(R"(^and in ([0-9]+) more variant\(s\))");
  static const std::regex first_in_variant(R"(^first in variant \[([^\]]*)\])");
  static const std::regex variant_count(R"(, in ([0-9]+) variants?\b)");
  static const std::regex pack_bindings(R"("bindings": \{"shifts": \[[^\]]*\]\} in the pack definition or )");
  static const std::regex cross_targets(R"(; if this pass does not need it, give the pass "targets" without .*$)");
  std::smatch match;
  if (std::regex_search(text, match, variant_note))
    text = "in the " + match[1].str() + " stage of " + file + with_defines(match[2].str()) + match.suffix().str();
  if (std::regex_search(text, match, more_variants))
    text = "and with " + match[1].str() + " other choice(s) of the file's keywords" + match.suffix().str();
  if (std::regex_search(text, match, first_in_variant)) {
    const std::string defines = with_defines(match[1].str());
    text = defines.empty() ? "" : "first" + defines;  // an empty note is dropped
  }
  if (std::regex_search(text, match, variant_count))
    text = match.prefix().str() + (match[1] == "1" ? "" : ", with " + match[1].str() + " choices of the file's -D keywords") +
           match.suffix().str();
  text = std::regex_replace(text, pack_bindings, "");
  text = std::regex_replace(text, cross_targets, ": compile for another --target");
  if (text.starts_with("pass 'main': ")) text.erase(0, std::string_view("pass 'main': ").size());
  if (text.starts_with("pass 'main', ")) text.erase(0, std::string_view("pass 'main', ").size());
  replace_all("pass 'main'", "'" + file + "'");
  replace_all("the pack definition", "the command line");
  return text;
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
                     "Stage: vertex, fragment, compute, geometry, hull, domain (or glslc's vert, frag, comp, geom, tesc, tese, "
                     "tesscontrol, tesseval; DXC's pixel, ps, vs, cs, gs, hs, ds)")
        ->required();
    entry_option_ = verb->add_option("-E,--entry", entry_, "Entry point (default: the one the file's '#pragma vertex NAME' or "
                                                          "'#pragma fragment NAME' names for the stage, else main)");
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
    std::string habits;
    for (const Habit& habit : kHabits)
      if (habit.refused.empty()) habits += (habits.empty() ? "" : ", ") + std::string(habit.spelling);
    verb->footer("glslc's and DXC's spellings that mean what kiln's do are read as kiln's: " + habits +
                 " (see docs/stages.md); others are refused with kiln's spelling.\n");
    return verb;
  }

  std::optional<int> rewrite_habits(std::vector<std::string>& arguments) override {
    std::vector<std::string> out;
    for (size_t i = 0; i < arguments.size(); ++i) {
      const std::string& argument = arguments[i];
      if (argument == "--") {  // the rest are file names
        out.insert(out.end(), arguments.begin() + static_cast<std::ptrdiff_t>(i), arguments.end());
        break;
      }
      const Habit* habit = nullptr;
      std::optional<std::string> value;
      for (const Habit& h : kHabits) {
        if ((h.takes == Takes::Joined || h.takes == Takes::JoinedOrNext) && argument.starts_with(std::string(h.spelling) + "=")) {
          value = argument.substr(h.spelling.size() + 1);
        } else if (h.takes == Takes::Next && h.tool == "DXC" && argument.size() > h.spelling.size() &&
                   argument.starts_with(h.spelling)) {
          value = argument.substr(h.spelling.size());  // DXC's -Tps_6_0, -Fox.spv
        } else if (argument != h.spelling) {
          continue;
        }
        habit = &h;
        break;
      }
      if (!habit) {
        out.push_back(argument);
        continue;
      }
      const std::string spelled = value ? argument : std::string(habit->spelling);
      if ((habit->takes == Takes::Next || habit->takes == Takes::JoinedOrNext) && !value) {
        if (i + 1 == arguments.size()) return command_line_error(spelled + " needs a value");
        value = arguments[++i];
      }
      if (habit->takes == Takes::Joined && !value) return command_line_error(spelled + " needs '=VALUE'");
      if (!habit->refused.empty())
        return command_line_error(std::string(habit->tool) + "'s '" + spelled + "' is not kiln's: " + std::string(habit->refused) +
                                  (habit->kiln.empty() ? std::string() : ": use '" + std::string(habit->kiln) + "'"));
      std::vector<std::string> kiln = words_of(habit->kiln);
      switch (habit->reading) {
        case Reading::Rename:
          break;
        case Reading::Profile: {
          Result<std::string> stage = stage_of_profile(*value);
          if (!stage) return command_line_error(stage.error().message);
          value = *stage;
          break;
        }
        case Reading::HlslOnly:
          if (*value != "hlsl") return command_line_error("-x '" + *value + "': kiln compiles HLSL only; for HLSL, use '-x hlsl' or nothing");
          value.reset();
          break;
        case Reading::DepfileBesideOutput:
          depfile_beside_output_ = true;
          break;
        case Reading::OptimizeUnlessValued:
          if (i + 1 < arguments.size() && (arguments[i + 1] == "s" || arguments[i + 1] == "0")) kiln = {"-O"};  // kiln's -O s
          break;
        case Reading::TargetEnvironment:
          if (Result<void> honoured = check_target_environment(habit->spelling, *value); !honoured)
            return command_line_error(honoured.error().message);
          value.reset();  // what kiln builds anyway
          break;
        case Reading::HlslVersion:
          if (std::find(std::begin(kHlslVersions), std::end(kHlslVersions), *value) == std::end(kHlslVersions))
            return command_line_error("-HV '" + *value + "': kiln's HLSL front end, glslang 12, reads HLSL 2018 and, of HLSL 2021, "
                                      "select, and and or (not templates, operator overloading or bit fields): use '-HV 2021', "
                                      "'-HV 2018' or nothing");
          value.reset();
          break;
      }
      out.insert(out.end(), kiln.begin(), kiln.end());
      if (value) out.push_back(*value);
    }
    arguments = std::move(out);
    return std::nullopt;
  }

  int run() override {
    const std::optional<Stage> stage = stage_from(stage_text_);
    const std::optional<Target> target = target_for(target_text_, output_);
    if (!stage) return command_line_error(unknown_stage(stage_text_));
    if (!target) return command_line_error("--target '" + target_text_ + "' is no target (expected " + target_name_list() + ")");
    // glslc's -MD without -MF: the depfile is named after the output.
    if (depfile_beside_output_ && depfile_.empty()) {
      if (output_ == "-") return command_line_error("-MD with -o -: no output file to name the depfile after: use '--depfile FILE'");
      depfile_ = output_ + ".d";
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
    // Without -E the stage's entry point is the default, which a Unity stage pragma in the file overrides.
    const json stage_entry = entry_option_->count() > 0 ? json(entry_) : json{{"source", std::filesystem::absolute(file_, ec).string()}};
    json pack{{"name", "compile"},
              {"include_dirs", include_dirs},
              {"targets", json::array({std::string(target_name(*target))})},
              {"passes", json::array({{{"name", "main"},
                                       {"source", std::filesystem::absolute(file_, ec).string()},
                                       {"stages", {{std::string(stage_name(*stage)), stage_entry}}}}})}};
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
    sink.set_listener([&pack_file, this](const Diagnostic& d) {
      Diagnostic shown = d;
      if (shown.location.path == pack_file.string() || shown.location.path == display_path(pack_file)) {
        shown.location = SourceLocation{"<command line>", 0, 0};
        shown.source_line.reset();
      }
      shown.message = in_file_and_stage_words(shown.message, file_);
      for (std::string& note : shown.notes) note = in_file_and_stage_words(note, file_);
      std::erase(shown.notes, std::string());
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

  CLI::Option* entry_option_ = nullptr;
  std::string file_, stage_text_, entry_ = "main", output_, target_text_, depfile_, optimize_ = "s";
  std::vector<std::string> include_dirs_;
  PlanArguments plan_;
  bool werror_ = false;
  bool debug_ = false;
  bool depfile_beside_output_ = false;  // glslc's -MD
};

}  // namespace

std::unique_ptr<Verb> make_compile_verb() { return std::make_unique<CompileVerb>(); }

}  // namespace kiln::cli
