// SPDX-License-Identifier: Apache-2.0
// What several verbs share: colour, diagnostics, the plan arguments, kiln-verify's verbs, the version text.
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <sstream>
#include <string_view>

#include "allocator.hpp"
#include "cli.hpp"
#include "kiln/command_line.hpp"

namespace kiln::cli {
namespace {

bool g_colour = false;

}  // namespace

void set_colour(const std::string& mode) { g_colour = stderr_wants_colour(mode); }

bool colour() { return g_colour; }

void print_diagnostics_as_they_come(DiagnosticSink& sink) {
  sink.set_listener([](const Diagnostic& d) { std::cerr << format_diagnostic(d, g_colour); });
}

std::string seconds_text(std::chrono::milliseconds duration) {
  std::ostringstream out;
  out << std::chrono::duration<double>(duration).count();
  return out.str();
}

void add_worker_and_cache_options(CLI::App* verb, BuildOptions& options, std::string& cache_dir, bool& no_cache) {
  verb->add_option("-j,--jobs", options.jobs, "Compiler worker processes (default, or 0: one per core)");
  auto* cache = verb->add_option("--cache", cache_dir, "Cache directory (default: ./.kiln-cache)");
  verb->add_flag("--no-cache", no_cache, "Do not read or write the cache")->excludes(cache);
  verb->add_option("--cache-max-mb", options.cache_max_mb,
                   "Cache size limit: least recently used entries go first (default: " + std::to_string(defaults::kCacheMaxMb) + ")")
      ->check(CLI::PositiveNumber);
}

void PlanArguments::add_to(CLI::App* verb, bool scenes) {
  if (scenes)
    verb->add_option("--scene", scenes_, "Scene profile (JSON); keep only variants some scene can request")->check(CLI::ExistingFile);
  verb->add_option("-D,--define", define_texts_, "Preprocessor define NAME or NAME=VALUE (repeatable; wins over the pack's)");
  verb->add_option("--keyword-kind", kind_texts_,
                   "KEYWORD[,KEYWORD...]=KIND: build the group of these keywords as KIND (" + keyword_kind_list() +
                       "), over the pack's keyword_kinds (repeatable)");
  for (char c : std::string("btsu"))
    verb->add_option(std::string("--fvk-") + c + "-shift", shift_texts_[c],
                     std::string("N SPACE: shift the bindings of ") + c + " registers in SPACE (a number or 'all') by N (repeatable)");
  verb->add_option("--fvk-bind-globals", globals_text_, "N M: the implicit $Global uniform block at binding N, set M");
  verb->add_flag("--auto-bind", auto_bind_, "Bind resources that declare no register automatically (the default)");
  verb->add_flag("--no-auto-bind", no_auto_bind_, "Do not bind resources that declare no register automatically");
  verb->add_flag("--combined-image-samplers", combined_, "A texture and a sampler at one register number become one combined binding");
  verb->add_flag("--separate-image-samplers", separate_, "Keep textures and samplers apart (the default)");
}

bool PlanArguments::apply(BuildOptions& options) const {
  for (const std::string& scene : scenes_) options.scene_files.push_back(scene);
  DiagnosticSink sink;
  print_diagnostics_as_they_come(sink);
  bool ok = true;
  if (auto defines = parse_command_line_defines(define_texts_, sink)) options.defines = *defines;
  else ok = false;
  if (auto kinds = parse_command_line_keyword_kinds(kind_texts_, sink)) options.keyword_kinds = *kinds;
  else ok = false;
  for (const auto& [letter, list] : shift_texts_)
    for (const auto& [shift, space] : list)
      ok = parse_command_line_shift(*parse_register_class(std::string(1, letter)), shift, space, options.bindings, sink) && ok;
  if (!globals_text_.first.empty())
    ok = parse_command_line_globals(globals_text_.first, globals_text_.second, options.bindings, sink) && ok;
  if (auto_bind_ || no_auto_bind_) options.bindings.auto_bind = !no_auto_bind_;
  if (combined_ || separate_) options.bindings.combined_image_samplers = !separate_;
  return ok;
}

std::optional<std::filesystem::path> find_verify() {
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
  for (const std::filesystem::path& candidate : candidates)
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  return std::nullopt;
}

std::string no_verify_message(const std::string& verb) {
  return "'kiln " + verb + "' runs kiln-verify, which this installation does not have (configure kiln with "
         "-DKILN_BUILD_VERIFY=ON, or set KILN_VERIFY to its path)";
}

int run_verify(int argc, char** argv) {
  const std::optional<std::filesystem::path> verify = find_verify();
  if (!verify) {
    std::cerr << "kiln: error: " << no_verify_message(argv[1]) << "\n";
    return 1;
  }
  std::vector<char*> args(argv, argv + argc);
  std::string program = verify->string();
  args[0] = program.data();
  args.push_back(nullptr);
  ::execv(program.c_str(), args.data());
  std::cerr << "kiln: error: cannot run " << program << ": " << std::strerror(errno) << "\n";
  return 1;
}

std::filesystem::path make_scratch(const std::string& prefix) {
  std::vector<std::filesystem::path> places;
  if (const char* tmpdir = std::getenv("TMPDIR"); tmpdir && *tmpdir) places.emplace_back(tmpdir);
  places.insert(places.end(), {"/tmp", "/var/tmp"});
  for (const std::filesystem::path& place : places) {
    std::string candidate = (place / (prefix + "XXXXXX")).string();
    if (::mkdtemp(candidate.data())) return candidate;
  }
  return {};
}

std::string version_text() {
  return std::string("kiln ") + kiln::kKilnVersion + "\n" + kiln::toolchain_description() + "allocator: " +
         kiln::allocator_description();
}

std::optional<std::vector<std::pair<std::string, std::string>>> parse_usage_tags(const std::vector<std::string>& tags) {
  std::vector<std::pair<std::string, std::string>> pairs;
  for (const std::string& tag : tags) {
    const size_t equals = tag.find('=');
    if (equals == std::string::npos || equals == 0) {
      std::cerr << "kiln: error: --usage-tag '" << tag << "' is not KEY=VALUE\n";
      return std::nullopt;
    }
    pairs.emplace_back(tag.substr(0, equals), tag.substr(equals + 1));
  }
  return pairs;
}

}  // namespace kiln::cli
