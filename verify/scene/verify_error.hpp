// SPDX-License-Identifier: Apache-2.0
// verify/'s errors: each carries a diagnostic of kiln's one table (the K20xx rows of diagnostics.def, and K1601 for
// an output that cannot be written), so kiln-verify prints them through kiln's formatter and exits with their class:
// 1 the input's fault (a scene, tolerance or golden file, a pack the renderer cannot use), 3 the machine's (no
// lavapipe, an image that cannot be written), 2 kiln's own (a driver call that fails on a module kiln built). Any
// other exception that escapes is a bug, reported by the guarded entry point (kiln/guarded_main.hpp).
#pragma once

#include <filesystem>
#include <istream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "kiln/diagnostics.hpp"
#include "kiln/pack_reader.hpp"

namespace kiln::render {

class VerifyError : public std::runtime_error {
 public:
  explicit VerifyError(Diagnostic diagnostic);
  const Diagnostic& diagnostic() const { return diagnostic_; }
  // The exit status its class gives (diagnostics.def).
  int exit_status() const;

 private:
  Diagnostic diagnostic_;
};

// Throws a VerifyError about `path` (empty: about no file), at line and column when known.
[[noreturn]] void fail(DiagId id, const std::filesystem::path& path, const std::string& message, int line = 0,
                       int column = 0);
// An error located by a reader's "file:line:col" text (PackError::file(); empty: about no file).
VerifyError error_at(DiagId id, const std::string& located_file, const std::string& message);

// Parses a JSON file verify reads; a syntax error is `id` at the line and column nlohmann reports.
nlohmann::json parse_json_file(std::istream& in, const std::filesystem::path& path, DiagId id);

// Prints a VerifyError through kiln's formatter (in colour by NO_COLOR and the terminal, as kiln's --color=auto) and
// returns its exit status.
int report(const VerifyError& error);

// A reader's error as verify's: the pack's files are the input (K2004); a request the pack cannot serve (an unknown
// pass or keyword, a stripped variant) is the command line's (K2005).
VerifyError pack_error(const PackError& error);

// Runs a verb of kiln-verify or kiln-reference. Its errors (VerifyError, and the reader's) are printed through kiln's
// formatter and give their class's exit status; any other exception escapes to the guarded entry point
// (kiln/guarded_main.hpp): a bug, exit 2.
template <typename Run>
int reporting_errors(Run&& run) {
  try {
    return run();
  } catch (const VerifyError& e) {
    return report(e);
  } catch (const PackError& e) {
    return report(pack_error(e));
  }
}

}  // namespace kiln::render
