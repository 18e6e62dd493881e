// SPDX-License-Identifier: Apache-2.0
// Diagnostics: one table of stable IDs (diagnostics.def), a sink that collects every
// message of a run, and the clang-like printer `path:line:col: error[K1234]: message`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace kiln {

enum class Severity : uint8_t { Note, Warning, Error };

// Whose fault an error is, and so the exit status (diagnostics.def's header): the input's (1), the machine's or the
// network's (3: running again may succeed), or kiln's own (2).
enum class ExitClass : uint8_t { Input, Environment, Internal };

enum class DiagId : uint16_t {
#define KILN_DIAGNOSTIC(number, name, severity, exit_class, description) name = number,
#include "kiln/diagnostics.def"
#undef KILN_DIAGNOSTIC
};

struct DiagInfo {
  DiagId id;
  std::string_view name;
  Severity severity;
  ExitClass exit_class;
  std::string_view description;
};

// Every entry of the table, in ID order.
const std::vector<DiagInfo>& diagnostic_table();
const DiagInfo& diagnostic_info(DiagId id);
// "K1201"
std::string diagnostic_code(DiagId id);

// A position in a user's file: 1-based line and column, 0 when unknown.
struct SourceLocation {
  std::string path;
  int line = 0;
  int column = 0;
};

// The line and column (1-based) of byte `offset` of `text`, a file at `path`.
SourceLocation location_of_offset(const std::string& path, std::string_view text, size_t offset);

struct Diagnostic {
  DiagId id{};
  Severity severity = Severity::Error;
  SourceLocation location;
  std::string message;
  std::vector<std::string> notes;  // printed as indented "note:" lines
  // The text of the line at `location`, quoted under the message. Filled by the sink from a file kiln
  // itself read (DiagnosticSink::add_source), never read again from disk: a `#line` directive can name
  // any path, and printing it would leak files outside the include roots (/proc/self/environ...).
  std::optional<std::string> source_line;
};

// Collects diagnostics from any thread; a run reports everything it found, not just the first.
class DiagnosticSink {
 public:
  using Listener = std::function<void(const Diagnostic&)>;

  void report(Diagnostic diagnostic);
  void report(DiagId id, SourceLocation location, std::string message, std::vector<std::string> notes = {});
  // Called for each diagnostic as it arrives (the CLI prints here).
  void set_listener(Listener listener);
  // A file kiln read under its safety rules (read_text_file): diagnostics located in it quote its lines.
  // Diagnostics naming any other path are shown by name only.
  void add_source(const std::string& path, std::shared_ptr<const std::string> text);

  bool has_errors() const;
  int error_count() const;
  int warning_count() const;
  std::vector<Diagnostic> diagnostics() const;
  bool contains(DiagId id) const;

 private:
  mutable std::mutex mutex_;
  std::vector<Diagnostic> diagnostics_;
  Listener listener_;
  std::map<std::string, std::shared_ptr<const std::string>, std::less<>> sources_;
};

// A quoted source line is cut to this many bytes: a minified or hostile file can hold one huge line.
inline constexpr size_t kMaxQuotedLineBytes = 400;

// The exit status of a class: Input 1, Internal 2, Environment 3.
int exit_status(ExitClass exit_class);
// A run's exit status from its errors: the worst class among them (Internal, then Environment, then Input); 0 when
// it has none (warnings do not count here: --werror is the verb's).
int exit_code(const DiagnosticSink& sink);
// The worse of two exit statuses by the same order (2, then 3, then 1, then 0).
int worse_exit_status(int a, int b);

// Renders a diagnostic with its quoted source line (if any) and a caret under the column. Reads no file.
// With `colour`, in ANSI colours as GCC and clang use them: the location and message bold, the severity in
// red (error), magenta (warning) or cyan (note), the caret green; the text is otherwise the same.
std::string format_diagnostic(const Diagnostic& diagnostic, bool colour = false);

// Whether diagnostics on stderr are coloured, by kiln's --color modes: "always", "never", or "auto" (stderr is a
// terminal, TERM is set and not "dumb", and NO_COLOR is unset or empty: no-color.org).
bool stderr_wants_colour(std::string_view mode);

// Edit distance, used to suggest the closest known name.
size_t edit_distance(std::string_view a, std::string_view b);
std::optional<std::string> closest_match(std::string_view word, const std::vector<std::string>& candidates);

}  // namespace kiln
