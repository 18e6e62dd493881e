// SPDX-License-Identifier: Apache-2.0
// kiln lint: a pack definition (every rule, over a scratch build) or HLSL files (the source rules), reported as
// text, JSON or SARIF (kiln/lint.hpp).
#include <stdlib.h>

#include <algorithm>
#include <cstdlib>
#include <iostream>

#include "cli.hpp"
#include "kiln/files.hpp"
#include "kiln/lint.hpp"

namespace kiln::cli {
namespace {

class LintVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("lint", "Lint a pack definition (every rule) or HLSL files (source rules); exit 1 on errors");
    // No CLI11 existence check: a missing input is a finding in the chosen format (an empty SARIF file breaks
    // a CI upload step with a confusing message).
    verb->add_option("inputs", inputs_, "A pack definition (.json), or HLSL files")->required();
    auto* cache_opt = verb->add_option("--cache", cache_dir_, "Cache directory for pack lint (default: ./.kiln-cache, the one kiln build uses)");
    verb->add_flag("--no-cache", no_cache_, "Do not read or write the cache")->excludes(cache_opt);
    plan_.add_to(verb);
    verb->add_option("-I,--include-dir", include_dirs_, "Include root for the files' #include (file mode; repeatable)");
    verb->add_option("--format", format_, "Output: text, json or sarif")->check(CLI::IsMember({"text", "json", "sarif"}));
    verb->add_option("-o,--output", output_,
                     "Write the report to this file (only when lint ran: never an empty or partial file); - for standard output");
    verb->add_option("--sarif-root", sarif_root_, "SARIF URIs are relative to this directory (default: the git work tree, else the current directory)");
    verb->add_flag("--werror", werror_, "Treat warnings as errors");
    std::vector<std::string> rule_ids(kiln::kRuleIdTexts.begin(), kiln::kRuleIdTexts.end());
    verb->add_option("--disable", disabled_,
                     "Rules that are off, RULE[,RULE...] (repeatable): their findings are suppressed, never counted")
        ->delimiter(',')
        ->check(CLI::IsMember(rule_ids));
    return verb;
  }

  int run() override {
    if (!plan_.apply(options_)) return 1;
    kiln::LintOptions lint;
    for (const std::string& rule : disabled_) lint.disabled.push_back(*kiln::parse_rule_id(rule));  // checked by CLI11
    kiln::LintReport report;
    if (inputs_.size() == 1 && inputs_[0].ends_with(".json")) {
      // The pack is built into a scratch directory under $TMPDIR, else /tmp, else /var/tmp (as gcc falls back).
      std::error_code ec;
      const std::string temp = make_scratch("kiln-lint-").string();
      if (temp.empty()) {
        const char* tmpdir = std::getenv("TMPDIR");
        std::cerr << "kiln lint: error[K1601]: cannot create a scratch directory under '" << (tmpdir && *tmpdir ? tmpdir : "(TMPDIR unset)")
                  << "', /tmp or /var/tmp" << (output_.empty() ? "" : "; '" + output_ + "' was not written") << "\n";
        return kiln::exit_status(kiln::ExitClass::Environment);
      }
      options_.pack_file = inputs_[0];
      options_.output_dir = temp;
      // build's default cache: a CI job that lints and then builds a pack compiles each module once.
      if (!no_cache_) options_.cache_dir = cache_dir_.empty() ? std::filesystem::path(".kiln-cache") : std::filesystem::path(cache_dir_);
      report = kiln::lint_pack(options_, lint);
      // A finding that names a file in the scratch directory (an internal compiler error's reproducer) keeps it.
      const bool referenced = std::any_of(report.findings.begin(), report.findings.end(), [&](const kiln::LintFinding& f) {
        return std::any_of(f.notes.begin(), f.notes.end(), [&](const std::string& note) { return note.find(temp) != std::string::npos; });
      });
      if (!referenced) std::filesystem::remove_all(temp, ec);
    } else {
      std::vector<std::filesystem::path> files(inputs_.begin(), inputs_.end());
      report = kiln::lint_files(files, std::vector<std::filesystem::path>(include_dirs_.begin(), include_dirs_.end()),
                                options_.defines, lint);
    }
    std::string text;
    if (format_ == "json") text = kiln::format_lint_json(report);
    else if (format_ == "sarif") text = kiln::format_lint_sarif(report, {sarif_root_.empty() ? kiln::default_sarif_root(std::filesystem::current_path()) : std::filesystem::path(sarif_root_)});
    else text = kiln::format_lint_text(report, output_.empty() && colour());  // a file or a pipe gets no escape codes
    if (output_ == "-") {
      std::cout << text << std::flush;
    } else if (!output_.empty()) {
      if (kiln::Result<void> written = kiln::write_output_file(output_, text); !written) {
        std::cerr << output_ << ": error[K1601]: " << written.error().message << "\n";
        return kiln::exit_status(kiln::ExitClass::Environment);
      }
    } else {
      (format_ == "text" ? std::cerr : std::cout) << text;
    }
    if (format_ == "text")
      std::cerr << "kiln lint: " << report.errors() << " error(s), " << report.warnings() << " warning(s)"
                << (report.suppressed() > 0 ? ", " + std::to_string(report.suppressed()) + " suppressed" : std::string()) << "\n";
    return report.errors() > 0 || (werror_ && report.warnings() > 0) ? 1 : 0;
  }

 private:
  kiln::BuildOptions options_;
  PlanArguments plan_;
  std::vector<std::string> inputs_, include_dirs_, disabled_;
  std::string cache_dir_, format_ = "text", output_, sarif_root_;
  bool no_cache_ = false, werror_ = false;
};

}  // namespace

std::unique_ptr<Verb> make_lint_verb() { return std::make_unique<LintVerb>(); }

}  // namespace kiln::cli
