// SPDX-License-Identifier: Apache-2.0
#include "driver/messages.hpp"

#include <algorithm>
#include <cctype>
#include <optional>
#include <string_view>

#include "common/files.hpp"
#include "common/line_tokens.hpp"

namespace kiln {
namespace {

bool is_directive(const std::string& line_text) {
  const size_t first = line_text.find_first_not_of(" \t");
  return first != std::string::npos && line_text[first] == '#';
}

}  // namespace

std::string variant_description(const Plan& plan, uint32_t pass, Stage stage, const std::vector<std::string>& keywords) {
  // A stage source's defines end with its folded keywords' macros (K=..., KILN_GROUP_OF_K=..., KILN_FOLDED_K):
  // named once, as folded.
  std::vector<std::string> chosen, folded;
  for (const std::string& k : keywords) {
    if (k.starts_with("KILN_FOLDED_")) folded.push_back(k.substr(std::string_view("KILN_FOLDED_").size()));
    else if (k.find('=') == std::string::npos) chosen.push_back(k);
  }
  return "pass '" + plan.pack.passes[pass].name + "' " + std::string(stage_name(stage)) + " stage, keywords [" +
         join_keywords(chosen) + "]" + (folded.empty() ? "" : ", folded [" + join_keywords(folded) + "]");
}

// "';' : Expected" quotes the token glslang wanted, not the one it found: the caret would land on some other
// ';' of the line, so such a message gets no column (printed `path:line:`, never a made-up one).
int guess_column(const std::string& line_text, const std::string& message) {
  if (message.size() < 3 || message[0] != '\'') return 0;
  size_t close = message.find('\'', 1);
  if (close == std::string::npos || close == 1) return 0;
  if (message.compare(close, std::string::npos, "' : Expected") == 0) return 0;
  // A preprocessor error ('#define' : bad argument, 'preprocessor evaluation' : bad expression) is about the
  // directive of its line: the caret goes under its '#'.
  const std::string quoted = message.substr(1, close - 1);
  if (quoted.starts_with('#') || quoted == "preprocessor evaluation") {
    const size_t hash = line_text.find_first_not_of(" \t");
    return hash != std::string::npos && line_text[hash] == '#' ? static_cast<int>(hash) + 1 : 0;
  }
  size_t at = line_text.find(quoted);
  return at == std::string::npos ? 0 : static_cast<int>(at) + 1;
}

namespace {

// The column of the `occurrence`-th token `token` of the file's line (FrontendMessage::token); 0 when the line has
// fewer (a macro on the line made them): no caret rather than a wrong one.
int token_column(const std::string& line_text, const std::string& token, int occurrence) {
  int seen = 0;
  for (const auto& [begin, end] : line_tokens(line_text))
    if (std::string_view(line_text).substr(begin, end - begin) == token && ++seen == occurrence) return static_cast<int>(begin) + 1;
  return 0;
}

}  // namespace

std::string quoted_name(const std::string& message) {
  const size_t open = message.find('\'');
  const size_t close = open == std::string::npos ? open : message.find('\'', open + 1);
  return close == std::string::npos ? std::string() : message.substr(open + 1, close - open - 1);
}

SourceLocator::SourceLocator(const Plan& plan) : plan_(plan) {
  for (const auto& [path, file] : plan.sources.files) by_name_[display_path(path)] = path;
}

std::string SourceLocator::line(const std::string& display_name, int line) const {
  auto it = by_name_.find(display_name);
  if (it == by_name_.end() || line <= 0) return {};
  const SourceFile* file = plan_.sources.find(it->second);
  if (!file) return {};
  size_t start = 0;
  for (int i = 1; i < line; ++i) {
    start = file->text.find('\n', start);
    if (start == std::string::npos) return {};
    ++start;
  }
  size_t end = file->text.find('\n', start);
  return file->text.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

SourceLocation SourceLocator::located(const FrontendMessage& m, const std::string& fallback) const {
  SourceLocation at{m.path.empty() ? fallback : m.path, m.line, m.column};
  // glslang's preprocessor reads a directive's newline before it reports, so its errors name the next line.
  const bool about_directive = m.text.starts_with("'#") || m.text.starts_with("'preprocessor evaluation'");
  if (about_directive && at.line > 1 && !is_directive(line(at.path, at.line)) && is_directive(line(at.path, at.line - 1)))
    --at.line;
  if (at.column == 0 && !m.token.empty()) at.column = token_column(line(at.path, at.line), m.token, m.occurrence);
  if (at.column == 0) at.column = guess_column(line(at.path, at.line), m.text);
  return at;
}

std::optional<std::pair<SourceLocation, uint32_t>> SourceLocator::constant_id(uint32_t pass,
                                                                             const std::set<uint32_t>& ids) const {
  static const std::string kAttribute = "constant_id";
  for (const std::filesystem::path& path : plan_.declarations[pass].files) {
    const SourceFile* file = plan_.sources.find(path);
    if (!file) continue;
    const std::vector<std::string> lines = code_lines(file->text);
    for (size_t l = 0; l < lines.size(); ++l) {
      const std::string& line = lines[l];
      for (size_t at = line.find(kAttribute); at != std::string::npos; at = line.find(kAttribute, at + 1)) {
        size_t p = at + kAttribute.size();
        while (p < line.size() && (line[p] == ' ' || line[p] == '\t')) ++p;
        if (p == line.size() || line[p] != '(') continue;
        ++p;
        while (p < line.size() && (line[p] == ' ' || line[p] == '\t')) ++p;
        const size_t digits = p;
        uint64_t id = 0;
        while (p < line.size() && std::isdigit(static_cast<unsigned char>(line[p])) && id < (uint64_t{1} << 32))
          id = id * 10 + static_cast<uint64_t>(line[p++] - '0');
        if (p == digits || !ids.count(static_cast<uint32_t>(id))) continue;
        return std::make_pair(SourceLocation{display_path(path), static_cast<int>(l + 1), static_cast<int>(digits + 1)},
                              static_cast<uint32_t>(id));
      }
    }
  }
  return std::nullopt;
}

SourceLocation SourceLocator::declaration(uint32_t pass, const std::string& name, const std::string& entry_name,
                                         const std::filesystem::path& first) const {
  if (name.empty()) return SourceLocation{entry_name, 0, 0};
  auto word_char = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  // A declaration: a type before the name (a word that is not `return`, or a template's `>`), and after it `:`,
  // `;`, `[`, `{`, `=` or the line's end; not a use (`albedo.Sample(`, `return albedo;`, a parameter).
  auto declares = [&](const std::string& line, size_t at, size_t end) {
    size_t before = at;
    while (before > 0 && (line[before - 1] == ' ' || line[before - 1] == '\t')) --before;
    if (before == at || before == 0 || !(word_char(line[before - 1]) || line[before - 1] == '>')) return false;
    size_t word = before;
    while (word > 0 && word_char(line[word - 1])) --word;
    if (line.compare(word, before - word, "return") == 0) return false;
    size_t after = end;
    while (after < line.size() && (line[after] == ' ' || line[after] == '\t')) ++after;
    return after == line.size() || std::string_view(":;[{=").find(line[after]) != std::string_view::npos;
  };
  // The declaration first; else the first mention (a declaration spelled some other way).
  std::optional<SourceLocation> first_mention;
  std::vector<std::filesystem::path> files = plan_.declarations[pass].files;
  if (auto it = std::find(files.begin(), files.end(), first); !first.empty() && it != files.end())
    std::rotate(files.begin(), it, it + 1);
  for (const std::filesystem::path& path : files) {
    const SourceFile* file = plan_.sources.find(path);
    if (!file) continue;
    std::vector<std::string> lines = code_lines(file->text);
    for (size_t l = 0; l < lines.size(); ++l) {
      for (size_t at = lines[l].find(name); at != std::string::npos; at = lines[l].find(name, at + 1)) {
        const bool starts = at == 0 || !word_char(lines[l][at - 1]);
        const size_t end = at + name.size();
        const bool ends = end == lines[l].size() || !word_char(lines[l][end]);
        if (!starts || !ends) continue;
        const SourceLocation here{display_path(path), static_cast<int>(l + 1), static_cast<int>(at + 1)};
        if (declares(lines[l], at, end)) return here;
        if (!first_mention) first_mention = here;
      }
    }
  }
  return first_mention.value_or(SourceLocation{entry_name, 0, 0});
}

void MessageGroups::collect(DiagId id, SourceLocation at, const std::string& text, const std::string& variant, size_t order,
                            std::vector<std::string> notes) {
  auto key = std::make_tuple(static_cast<int>(id), at.path, at.line, text);
  auto [it, inserted] = index_.emplace(key, groups_.size());
  if (inserted) groups_.push_back({id, std::move(at), text, {}, std::move(notes)});
  groups_[it->second].variants.emplace_back(order, variant);
}

bool MessageGroups::has_errors() const {
  return std::any_of(groups_.begin(), groups_.end(),
                     [](const Group& g) { return diagnostic_info(g.id).severity == Severity::Error; });
}

void MessageGroups::report(DiagnosticSink& sink) {
  for (Group& g : groups_) std::sort(g.variants.begin(), g.variants.end());
  std::sort(groups_.begin(), groups_.end(), [](const Group& a, const Group& b) { return a.variants[0].first < b.variants[0].first; });
  for (const Group& g : groups_) {
    std::vector<std::string> notes{"in " + g.variants.front().second};
    if (g.variants.size() > 1) notes.push_back("and in " + std::to_string(g.variants.size() - 1) + " more variant(s)");
    if (g.id == DiagId::CrossCompileFailed && g.text.starts_with("cross-")) {  // "cross-gles: ..."
      const std::string target = g.text.substr(6, g.text.find_first_of(": ") - 6);
      notes.push_back("SPIRV-Cross cannot write this for the '" + target + "' target; if this pass does not need it, give the "
                      "pass \"targets\" without \"" + target + "\" (or remove it from the pack's, or build with --targets)");
    }
    notes.insert(notes.end(), g.notes.begin(), g.notes.end());
    sink.report(g.id, g.at, g.text, notes);
  }
  groups_.clear();
  index_.clear();
}

}  // namespace kiln
