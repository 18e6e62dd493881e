// SPDX-License-Identifier: Apache-2.0
#include "kiln/diagnostics.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <sstream>

namespace kiln {

const std::vector<DiagInfo>& diagnostic_table() {
  static const std::vector<DiagInfo> table = {
#define KILN_DIAGNOSTIC(number, name, severity, exit_class, description) \
  {DiagId::name, #name, Severity::severity, ExitClass::exit_class, description},
#include "kiln/diagnostics.def"
#undef KILN_DIAGNOSTIC
  };
  return table;
}

const DiagInfo& diagnostic_info(DiagId id) {
  for (const DiagInfo& info : diagnostic_table()) {
    if (info.id == id) return info;
  }
  static const DiagInfo unknown{id, "Unknown", Severity::Error, ExitClass::Internal, "unknown diagnostic"};
  return unknown;
}

int exit_status(ExitClass exit_class) {
  switch (exit_class) {
    case ExitClass::Input: return 1;
    case ExitClass::Internal: return 2;
    case ExitClass::Environment: return 3;
  }
  return 2;
}

int worse_exit_status(int a, int b) {
  auto rank = [](int status) { return status == 2 ? 3 : status == 3 ? 2 : status == 0 ? 0 : 1; };
  return rank(a) >= rank(b) ? a : b;
}

int exit_code(const DiagnosticSink& sink) {
  // The worst class wins: a bug in kiln over a machine that cannot take the outputs over a mistake in the input.
  bool input = false, environment = false;
  for (const Diagnostic& d : sink.diagnostics()) {
    if (d.severity != Severity::Error) continue;
    switch (diagnostic_info(d.id).exit_class) {
      case ExitClass::Internal: return exit_status(ExitClass::Internal);
      case ExitClass::Environment: environment = true; break;
      case ExitClass::Input: input = true; break;
    }
  }
  return environment ? exit_status(ExitClass::Environment) : input ? exit_status(ExitClass::Input) : 0;
}

std::string diagnostic_code(DiagId id) { return "K" + std::to_string(static_cast<unsigned>(id)); }

namespace {

// Line `line` (1-based) of `text`, cut to kMaxQuotedLineBytes; nothing past the end.
std::optional<std::string> line_of_text(std::string_view text, int line) {
  if (line <= 0) return std::nullopt;
  size_t start = 0;
  for (int i = 1; i < line; ++i) {
    start = text.find('\n', start);
    if (start == std::string_view::npos) return std::nullopt;
    ++start;
  }
  if (start >= text.size()) return std::nullopt;
  std::string_view found = text.substr(start, text.find('\n', start) - start);
  if (!found.empty() && found.back() == '\r') found.remove_suffix(1);
  if (found.size() > kMaxQuotedLineBytes) {
    found = found.substr(0, kMaxQuotedLineBytes);
    // Do not end inside a UTF-8 sequence.
    while (!found.empty() && (static_cast<unsigned char>(found.back()) & 0xC0) == 0x80) found.remove_suffix(1);
    if (!found.empty() && (static_cast<unsigned char>(found.back()) & 0xC0) == 0xC0) found.remove_suffix(1);
    return std::string(found) + " ...";
  }
  return std::string(found);
}

}  // namespace

void DiagnosticSink::add_source(const std::string& path, std::shared_ptr<const std::string> text) {
  if (path.empty() || !text) return;
  std::lock_guard lock(mutex_);
  sources_[path] = std::move(text);
}

void DiagnosticSink::report(Diagnostic diagnostic) {
  Listener listener;
  {
    std::lock_guard lock(mutex_);
    if (!diagnostic.source_line) {
      if (auto it = sources_.find(diagnostic.location.path); it != sources_.end())
        diagnostic.source_line = line_of_text(*it->second, diagnostic.location.line);
    }
    diagnostics_.push_back(diagnostic);
    listener = listener_;
  }
  if (listener) listener(diagnostic);
}

void DiagnosticSink::report(DiagId id, SourceLocation location, std::string message, std::vector<std::string> notes) {
  report(Diagnostic{id, diagnostic_info(id).severity, std::move(location), std::move(message), std::move(notes)});
}

void DiagnosticSink::set_listener(Listener listener) {
  std::lock_guard lock(mutex_);
  listener_ = std::move(listener);
}

bool DiagnosticSink::has_errors() const { return error_count() > 0; }

int DiagnosticSink::error_count() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(std::count_if(diagnostics_.begin(), diagnostics_.end(),
                                        [](const Diagnostic& d) { return d.severity == Severity::Error; }));
}

int DiagnosticSink::warning_count() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(std::count_if(diagnostics_.begin(), diagnostics_.end(),
                                        [](const Diagnostic& d) { return d.severity == Severity::Warning; }));
}

std::vector<Diagnostic> DiagnosticSink::diagnostics() const {
  std::lock_guard lock(mutex_);
  return diagnostics_;
}

bool DiagnosticSink::contains(DiagId id) const {
  std::lock_guard lock(mutex_);
  return std::any_of(diagnostics_.begin(), diagnostics_.end(), [id](const Diagnostic& d) { return d.id == id; });
}

namespace {

const char* severity_word(Severity severity) {
  switch (severity) {
    case Severity::Note: return "note";
    case Severity::Warning: return "warning";
    case Severity::Error: return "error";
  }
  return "error";
}

const char* severity_colour(Severity severity) {
  switch (severity) {
    case Severity::Note: return "\x1b[1;36m";
    case Severity::Warning: return "\x1b[1;35m";
    case Severity::Error: return "\x1b[1;31m";
  }
  return "\x1b[1;31m";
}

}  // namespace

std::string format_diagnostic(const Diagnostic& d, bool colour) {
  const char* bold = colour ? "\x1b[1m" : "";
  const char* reset = colour ? "\x1b[0m" : "";
  std::ostringstream out;
  out << bold;
  if (!d.location.path.empty()) {
    out << d.location.path;
    if (d.location.line > 0) out << ':' << d.location.line;
    if (d.location.line > 0 && d.location.column > 0) out << ':' << d.location.column;
    out << ": ";
  } else {
    out << "kiln: ";
  }
  out << (colour ? severity_colour(d.severity) : "") << severity_word(d.severity) << '[' << diagnostic_code(d.id) << "]:" << reset
      << bold << ' ' << d.message << reset << '\n';
  if (const std::optional<std::string>& line = d.source_line) {
    out << "    " << *line << '\n';
    if (d.location.column > 0) {
      std::string pad;
      // Keep tabs so the caret lines up under the same column in a terminal.
      for (int i = 0; i < d.location.column - 1 && i < static_cast<int>(line->size()); ++i)
        pad += (*line)[i] == '\t' ? '\t' : ' ';
      out << "    " << pad << (colour ? "\x1b[1;32m^\x1b[0m" : "^") << "\n";
    }
  }
  for (const std::string& note : d.notes)
    out << "  " << (colour ? severity_colour(Severity::Note) : "") << "note:" << reset << ' ' << note << '\n';
  return out.str();
}

SourceLocation location_of_offset(const std::string& path, std::string_view text, size_t offset) {
  SourceLocation location{path, 1, 1};
  for (size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++location.line;
      location.column = 1;
    } else {
      ++location.column;
    }
  }
  return location;
}

bool stderr_wants_colour(std::string_view mode) {
  if (mode == "always" || mode == "never") return mode == "always";
  const char* no_colour = std::getenv("NO_COLOR");
  const char* term = std::getenv("TERM");
  return !(no_colour && *no_colour) && ::isatty(2) && term && *term && std::string_view(term) != "dumb";
}

// Optimal string alignment distance: insertions, deletions, substitutions and swaps of two adjacent
// characters ("biuld" is one edit from "build"), each costing one.
size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<size_t> before(b.size() + 1), previous(b.size() + 1), row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) previous[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      row[j] = std::min({previous[j] + 1, row[j - 1] + 1, previous[j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) row[j] = std::min(row[j], before[j - 2] + 1);
    }
    std::swap(before, previous);
    std::swap(previous, row);
  }
  return previous[b.size()];
}

std::optional<std::string> closest_match(std::string_view word, const std::vector<std::string>& candidates) {
  std::optional<std::string> best;
  size_t best_distance = 0;
  for (const std::string& candidate : candidates) {
    size_t distance = edit_distance(word, candidate);
    if (!best || distance < best_distance || (distance == best_distance && candidate < *best)) {
      best = candidate;
      best_distance = distance;
    }
  }
  // Only a plausible typo is worth suggesting: at most a third of the word changed.
  if (best && best_distance * 3 <= std::max<size_t>(word.size(), 3)) return best;
  return std::nullopt;
}

}  // namespace kiln
