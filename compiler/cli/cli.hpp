// SPDX-License-Identifier: Apache-2.0
// kiln's command line: one file per verb (build_verb.cpp, list_verb.cpp, ...), each registering its options with
// CLI11 and running over the library; main.cpp only assembles them. What several verbs share is here.
#pragma once

#include <CLI/CLI.hpp>

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "kiln/build.hpp"

namespace kiln::cli {

// Diagnostics in colour (--color: auto, always, never). Auto: when stderr is a terminal and TERM is set and not
// "dumb", unless NO_COLOR is set to anything (no-color.org); always and never win over NO_COLOR.
void set_colour(const std::string& mode);
bool colour();
// Prints each diagnostic to stderr as the sink receives it.
void print_diagnostics_as_they_come(DiagnosticSink& sink);

// "120", "1", "0.5": a default in seconds as --help states it.
std::string seconds_text(std::chrono::milliseconds duration);
// --usage-tag KEY=VALUE arguments as pairs; nothing (the error printed) when one is not KEY=VALUE.
std::optional<std::vector<std::pair<std::string, std::string>>> parse_usage_tags(const std::vector<std::string>& tags);

// The arguments build, list and lint share: scene profiles, the binding model and defines (docs/bindings.md),
// in DXC's spellings.
class PlanArguments {
 public:
  void add_to(CLI::App* verb, bool scenes = true);
  // Into `options`: scenes, defines and binding options. False (with K1014 reported) when one is malformed.
  bool apply(BuildOptions& options) const;

 private:
  std::vector<std::string> scenes_;
  std::vector<std::string> define_texts_;
  std::vector<std::string> kind_texts_;
  std::map<char, std::vector<std::pair<std::string, std::string>>> shift_texts_;
  std::pair<std::string, std::string> globals_text_;
  bool auto_bind_ = false, no_auto_bind_ = false, combined_ = false, separate_ = false;
};

// -j, --cache, --no-cache and --cache-max-mb, as build and watch take them (the cache directory and the switch into
// `cache_dir` and `no_cache`, the rest into `options`).
void add_worker_and_cache_options(CLI::App* verb, BuildOptions& options, std::string& cache_dir, bool& no_cache);

// One verb: its options, registered on the app, and what it does once they are parsed.
class Verb {
 public:
  virtual ~Verb() = default;
  virtual CLI::App* add_to(CLI::App& app) = 0;
  // Before parsing: other tools' spellings of this verb's options (glslc's, DXC's) rewritten in `arguments` (those
  // after the verb) into kiln's; an exit status when one is refused, its hint printed.
  virtual std::optional<int> rewrite_habits(std::vector<std::string>& /*arguments*/) { return std::nullopt; }
  virtual int run() = 0;
};

std::unique_ptr<Verb> make_build_verb();
std::unique_ptr<Verb> make_list_verb();
std::unique_ptr<Verb> make_inspect_verb();
std::unique_ptr<Verb> make_lint_verb();
std::unique_ptr<Verb> make_check_scene_verb();
std::unique_ptr<Verb> make_check_usage_verb();
std::unique_ptr<Verb> make_merge_usage_verb();
std::unique_ptr<Verb> make_diff_packs_verb();
std::unique_ptr<Verb> make_compile_verb();
std::unique_ptr<Verb> make_fold_cost_verb();
std::unique_ptr<Verb> make_watch_verb();

// Rendering and golden tests are kiln-verify's verbs (it links Vulkan, EGL, PNG and OpenEXR; kiln does not):
// listed in --help, handed to kiln-verify before parsing.
struct VerifyVerb {
  const char* name;
  const char* description;
};
inline constexpr VerifyVerb kVerifyVerbs[] = {
    {"render", "Render a scene with one Forward variant of a pack (lavapipe or llvmpipe GL; runs kiln-verify)"},
    {"test", "Render every Forward variant and compare it with its CPU-reference golden (runs kiln-verify)"},
};
// kiln-verify: $KILN_VERIFY, next to kiln, then ../libexec/kiln, then the build tree; nothing when none is there.
std::optional<std::filesystem::path> find_verify();
std::string no_verify_message(const std::string& verb);
// Runs kiln-verify with kiln's arguments (in place of kiln).
int run_verify(int argc, char** argv);

// A scratch directory `<prefix>XXXXXX` under $TMPDIR, else /tmp, else /var/tmp (as gcc falls back); empty when
// none of them can hold one.
std::filesystem::path make_scratch(const std::string& prefix);

// kiln's version and every tool it was built with, as its cache keys and manifests name them.
std::string version_text();

}  // namespace kiln::cli
