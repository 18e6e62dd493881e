// SPDX-License-Identifier: Apache-2.0
// kiln check-scene and kiln diff-packs: questions about built packs (kiln/pack_tools.hpp).
#include <iostream>

#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "kiln/files.hpp"
#include "kiln/defaults.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/pack_tools.hpp"
#include "kiln/text.hpp"

namespace kiln::cli {
namespace {

using nlohmann::json;

int run_check_scene(const std::string& pack_dir, const std::string& scene, bool as_json) {
  kiln::DiagnosticSink sink;
  print_diagnostics_as_they_come(sink);
  try {
    kiln::PackReader pack = kiln::PackReader::open(pack_dir, kiln::PackReader::Check::Full);
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
    kiln::PackReader first = kiln::PackReader::open(a, kiln::PackReader::Check::Full),
                     second = kiln::PackReader::open(b, kiln::PackReader::Check::Full);
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

class CheckSceneVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("check-scene", "Report every variant a scene can request that a built pack lacks");
    verb->add_option("pack_dir", pack_dir_, "Directory holding a pack (or its manifest)")->required();
    verb->add_option("scene", scene_file_, "Scene profile (JSON)")->required()->check(CLI::ExistingFile);
    verb->add_flag("--json", as_json_, "Print JSON");
    return verb;
  }
  int run() override { return run_check_scene(pack_dir_, scene_file_, as_json_); }

 private:
  std::string pack_dir_, scene_file_;
  bool as_json_ = false;
};

class DiffPacksVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("diff-packs", "Show the variants added, removed or changed between two packs");
    verb->add_option("a", first_, "The old pack")->required();
    verb->add_option("b", second_, "The new pack")->required();
    verb->add_flag("--json", as_json_, "Print JSON");
    return verb;
  }
  int run() override { return run_diff_packs(first_, second_, as_json_); }

 private:
  std::string first_, second_;
  bool as_json_ = false;
};

// kiln check-usage PACK LOG...: before a narrower pack ships, which requests of recorded runs it would not serve.
class CheckUsageVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("check-usage", "Report every keyword set recorded usage logs asked for that a built pack lacks");
    verb->add_option("pack_dir", pack_dir_, "Directory holding a pack (or its manifest)")->required();
    verb->add_option("logs", logs_, "Usage logs (docs/usage.md)")->required();
    verb->add_option("--usage-tag", tags_, "Only the logs tagged KEY=VALUE (repeatable: every tag)");
    return verb;
  }
  int run() override {
    kiln::DiagnosticSink sink;
    print_diagnostics_as_they_come(sink);
    auto filters = parse_usage_tags(tags_);
    if (!filters) return 1;
    auto pack = kiln::PackReader::try_open(pack_dir_, kiln::PackReader::Check::Full);
    if (!pack) {
      std::cerr << (pack.file().empty() ? pack_dir_ : pack.file()) << ": error: " << pack.message() << "\n";
      return 1;
    }
    std::vector<kiln::UsageLog> logs;
    for (kiln::UsageLog& log : kiln::load_usage_logs(logs_, *filters, sink)) {
      if (log.pack != pack->name())
        sink.report(kiln::DiagId::UsageLog, kiln::usage_log_pack_location(log),
                    "this usage log is of pack '" + kiln::echoed(log.pack) + "', not of '" + pack->name() + "'");
      else
        logs.push_back(std::move(log));
    }
    const kiln::UsageCheck check = kiln::check_usage(*pack, logs, sink);
    std::cout << "kiln check-usage: " << kiln::counted(logs.size(), "log") << ", " << kiln::counted(check.sets, "keyword set")
              << " asked for (" << kiln::counted(check.requests, "selection") << "): " << check.missed << " not in the pack ("
              << kiln::counted(check.requests_missed, "selection") << ")\n";
    return sink.has_errors() ? 1 : 0;
  }

 private:
  std::string pack_dir_;
  std::vector<std::string> logs_, tags_;
};

// kiln merge-usage LOG... -o OUT: many runs' logs as one, with the counts added (docs/usage.md, "Merging logs").
class MergeUsageVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("merge-usage", "Merge usage logs into one, adding the counts (optionally only some tags and passes)");
    verb->add_option("logs", logs_, "Usage logs (docs/usage.md)")->required();
    verb->add_option("-o,--output", output_, "The merged log ('-': standard output)")->required();
    verb->add_option("--usage-tag", tags_, "Only the logs tagged KEY=VALUE (repeatable: every tag)");
    verb->add_option("--pass", passes_, "Only this pass (repeatable)");
    return verb;
  }
  int run() override {
    kiln::DiagnosticSink sink;
    print_diagnostics_as_they_come(sink);
    auto filters = parse_usage_tags(tags_);
    if (!filters) return 1;
    size_t left_out = 0;
    std::vector<kiln::UsageLog> logs = kiln::load_usage_logs(logs_, *filters, sink, &left_out);
    if (sink.has_errors()) return 1;
    if (logs.empty()) {
      std::cerr << "kiln merge-usage: error: none of the " << logs_.size() << " usage logs has the tags asked for\n";
      return 1;
    }
    auto merged = kiln::merge_usage_logs(logs, {passes_.begin(), passes_.end()}, sink);
    if (!merged) return 1;
    if (output_ == "-") {
      std::cout << merged->text << std::flush;
    } else if (kiln::Result<void> written = kiln::write_output_file(output_, merged->text); !written) {
      std::cerr << output_ << ": error[K1601]: " << written.error().message << "\n";
      return kiln::exit_status(kiln::ExitClass::Environment);
    }
    (output_ == "-" ? std::cerr : std::cout)
        << "kiln merge-usage: " << kiln::counted(logs.size(), "log") << " merged (" << left_out << " without the tags), "
        << kiln::counted(merged->passes, "pass", "passes") << ", " << kiln::counted(merged->sets, "keyword set") << ", "
        << kiln::counted(merged->selections, "selection")
        << (output_ == "-" ? std::string() : " -> " + output_) << "\n";
    return 0;
  }

 private:
  std::vector<std::string> logs_, tags_, passes_;
  std::string output_;
};

}  // namespace

std::unique_ptr<Verb> make_merge_usage_verb() { return std::make_unique<MergeUsageVerb>(); }
std::unique_ptr<Verb> make_check_usage_verb() { return std::make_unique<CheckUsageVerb>(); }
std::unique_ptr<Verb> make_check_scene_verb() { return std::make_unique<CheckSceneVerb>(); }
std::unique_ptr<Verb> make_diff_packs_verb() { return std::make_unique<DiffPacksVerb>(); }

}  // namespace kiln::cli
