// SPDX-License-Identifier: Apache-2.0
#include "scene/verify_error.hpp"

#include "kiln/bounded_json.hpp"

#include <iostream>
#include <regex>

namespace kiln::render {

VerifyError::VerifyError(Diagnostic diagnostic)
    : std::runtime_error(format_diagnostic(diagnostic)), diagnostic_(std::move(diagnostic)) {}

int VerifyError::exit_status() const { return kiln::exit_status(diagnostic_info(diagnostic_.id).exit_class); }

void fail(DiagId id, const std::filesystem::path& path, const std::string& message, int line, int column) {
  throw VerifyError(Diagnostic{id, Severity::Error, SourceLocation{path.string(), line, column}, message, {}});
}

VerifyError error_at(DiagId id, const std::string& located_file, const std::string& message) {
  static const std::regex kLocated(R"((.*):([0-9]{1,9}):([0-9]{1,9}))");
  std::smatch m;
  SourceLocation location{located_file, 0, 0};
  if (std::regex_match(located_file, m, kLocated)) location = {m[1].str(), std::stoi(m[2]), std::stoi(m[3])};
  return VerifyError(Diagnostic{id, Severity::Error, std::move(location), message, {}});
}

nlohmann::json parse_json_file(std::istream& in, const std::filesystem::path& path, DiagId id) {
  // Through kiln's one decoder of outside JSON (kiln/bounded_json.hpp): sizes, nesting and repeated keys checked.
  constexpr size_t kMaxBytes = size_t{16} << 20;
  std::string text(kMaxBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(in.gcount()));
  try {
    return parse_json_bounded(text, {kMaxBytes, kMaxJsonDepth});
  } catch (const JsonDecodeError& e) {
    const SourceLocation at = location_of_offset(path.string(), text, e.offset());
    fail(id, path, std::string("invalid JSON: ") + e.what(), at.line, at.column);
  }
}

int report(const VerifyError& error) {
  std::cerr << format_diagnostic(error.diagnostic(), stderr_wants_colour("auto"));
  return error.exit_status();
}

VerifyError pack_error(const PackError& error) {
  using Code = PackError::Code;
  const Code code = error.code();
  const bool request = code == Code::UnknownPass || code == Code::UnknownKeyword || code == Code::ConflictingKeywords ||
                       code == Code::MissingKeyword || code == Code::Stripped;
  return error_at(request ? DiagId::VerifyArgument : DiagId::PackUnusable, error.file(), error.what());
}

}  // namespace kiln::render
