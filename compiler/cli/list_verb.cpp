// SPDX-License-Identifier: Apache-2.0
// kiln list: every variant a pack would contain, with the keywords each stage sees, and each pass's settings.
#include <iostream>

#include <nlohmann/json.hpp>

#include "cli.hpp"

namespace kiln::cli {
namespace {

using nlohmann::json;

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

class ListVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("list", "List every variant a pack would contain, with the keywords each stage sees");
    verb->add_option("pack", pack_file_, "Pack definition")->required();
    plan_.add_to(verb);
    verb->add_flag("--json", as_json_, "Print JSON");
    return verb;
  }
  int run() override {
    kiln::BuildOptions options;
    options.pack_file = pack_file_;
    if (!plan_.apply(options)) return 1;
    return run_list(options, as_json_);
  }

 private:
  std::string pack_file_;
  PlanArguments plan_;
  bool as_json_ = false;
};

}  // namespace

std::unique_ptr<Verb> make_list_verb() { return std::make_unique<ListVerb>(); }

}  // namespace kiln::cli
