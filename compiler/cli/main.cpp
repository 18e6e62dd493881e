// SPDX-License-Identifier: Apache-2.0
// kiln: the command line. Each verb is a file of its own (cli.hpp); this file assembles them, parses, and runs
// the one chosen inside the one guarded entry point: an exception that escapes a verb is an internal error
// (exit 2, "this is a bug in kiln"), never an abort or an exit code that reads as the input's fault.
#include <cstring>
#include <iostream>

#include "cli.hpp"
#include "kiln/files.hpp"
#include "kiln/guarded_main.hpp"
#ifdef KILN_FAULT_INJECTION
#include "fault_injection.hpp"
#endif

namespace {

int run(int argc, char** argv) {
  for (const kiln::cli::VerifyVerb& verb : kiln::cli::kVerifyVerbs)
    if (argc > 1 && std::strcmp(argv[1], verb.name) == 0) return kiln::cli::run_verify(argc, argv);
  // Named, so that `Usage:` says kiln and not the path it was started by (build/ci/compiler/kiln).
  CLI::App app{"kiln: shader permutation compiler (HLSL -> SPIR-V, GLSL, GLSL ES, MSL variant packs)", "kiln"};
  app.require_subcommand(1);
  app.set_version_flag("--version", kiln::cli::version_text());
  std::string colour_mode = "auto";
  app.add_option("--color", colour_mode, "Colour diagnostics: auto (on a terminal, unless NO_COLOR is set), always, never")
      ->check(CLI::IsMember({"auto", "always", "never"}));
  app.fallthrough();  // --color also after the verb

  std::vector<std::pair<CLI::App*, std::unique_ptr<kiln::cli::Verb>>> verbs;
  for (auto make : {kiln::cli::make_build_verb, kiln::cli::make_list_verb, kiln::cli::make_inspect_verb,
                    kiln::cli::make_lint_verb, kiln::cli::make_check_scene_verb, kiln::cli::make_check_usage_verb,
                    kiln::cli::make_merge_usage_verb, kiln::cli::make_diff_packs_verb, kiln::cli::make_compile_verb,
                    kiln::cli::make_fold_cost_verb, kiln::cli::make_watch_verb}) {
    std::unique_ptr<kiln::cli::Verb> verb = make();
    CLI::App* command = verb->add_to(app);
    verbs.emplace_back(command, std::move(verb));
  }
  // Listed in --help only: run() hands both to kiln-verify before parsing.
  for (const kiln::cli::VerifyVerb& verb : kiln::cli::kVerifyVerbs) app.add_subcommand(verb.name, verb.description)->prefix_command();

  app.failure_message([](const CLI::App*, const CLI::Error& error) {
    return std::string("kiln: error: ") + error.what() + "\nRun with --help for more information.\n";
  });
  std::vector<std::string> names;
  for (const CLI::App* command : app.get_subcommands({})) names.push_back(command->get_name());
  if (argc > 1 && argv[1][0] != '-' && std::find(names.begin(), names.end(), argv[1]) == names.end()) {
    auto suggestion = kiln::closest_match(argv[1], names);
    std::cerr << "kiln: error: unknown command '" << argv[1] << "'"
              << (suggestion ? "; did you mean '" + *suggestion + "'?" : std::string()) << "\nRun with --help for more information.\n";
    return 1;
  }
  // The verb (the first word that is no option, --color's value aside) may rewrite habits of other tools first.
  std::vector<std::string> arguments(argv, argv + argc);
  for (size_t i = 1; i < arguments.size(); ++i) {
    if (arguments[i] == "--color") {
      ++i;
      continue;
    }
    if (arguments[i].starts_with('-')) continue;
    for (auto& [command, verb] : verbs) {
      if (command->get_name() != arguments[i]) continue;
      std::vector<std::string> rest(arguments.begin() + static_cast<std::ptrdiff_t>(i) + 1, arguments.end());
      if (std::optional<int> refused = verb->rewrite_habits(rest)) return *refused;
      arguments.resize(i + 1);
      arguments.insert(arguments.end(), rest.begin(), rest.end());
    }
    break;
  }
  std::vector<char*> rewritten;
  for (std::string& argument : arguments) rewritten.push_back(argument.data());
  try {
    app.parse(static_cast<int>(rewritten.size()), rewritten.data());
  } catch (const CLI::ParseError& error) {
    // --help and --version end here with 0; any other argument error is the user's: exit code 1, not CLI11's 100+.
    return app.exit(error) == 0 ? 0 : 1;
  }
  kiln::cli::set_colour(colour_mode);
  for (auto& [command, verb] : verbs) {
    if (!*command) continue;
#ifdef KILN_FAULT_INJECTION  // the tests' kiln-fault-cli only (tests/support/fault_injection.hpp)
    kiln::testing::inject_fault(command->get_name());
#endif
    return verb->run();
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return kiln::run_guarded([&] { return run(argc, argv); }); }
