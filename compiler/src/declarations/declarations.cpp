// SPDX-License-Identifier: Apache-2.0
#include "declarations/declarations.hpp"

#include "common/keyword_pragmas.hpp"

#include <algorithm>
#include <cctype>

namespace kiln {

const SourceFile* SourceSet::find(const std::filesystem::path& canonical) const {
  auto it = files.find(canonical);
  return it == files.end() ? nullptr : &it->second;
}

// Source lines with comments blanked out (same length, so columns stay true). Block comments may span lines.
std::vector<std::string> code_lines(std::string_view text) {
  std::vector<std::string> lines;
  std::string current;
  bool in_block = false;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    char c = text[i];
    if (c == '\n') {
      if (!current.empty() && current.back() == '\r') current.back() = ' ';
      lines.push_back(std::move(current));
      current.clear();
      in_string = false;
      continue;
    }
    if (in_block) {
      if (c == '*' && i + 1 < text.size() && text[i + 1] == '/') {
        current += "  ";
        ++i;
        in_block = false;
      } else {
        current += ' ';
      }
      continue;
    }
    if (!in_string && c == '/' && i + 1 < text.size() && text[i + 1] == '/') {
      while (i < text.size() && text[i] != '\n') {
        current += ' ';
        ++i;
      }
      --i;
      continue;
    }
    if (!in_string && c == '/' && i + 1 < text.size() && text[i + 1] == '*') {
      current += "  ";
      ++i;
      in_block = true;
      continue;
    }
    if (c == '"') in_string = !in_string;
    current += c;
  }
  lines.push_back(std::move(current));
  return lines;
}

namespace {

// Unity's stage pragmas (ShaderLab's CGPROGRAM/HLSLPROGRAM blocks, and `kernel` in compute shaders).
constexpr std::pair<std::string_view, Stage> kUnityStagePragmas[] = {
    {"vertex", Stage::Vertex}, {"fragment", Stage::Fragment}, {"geometry", Stage::Geometry},
    {"hull", Stage::Hull},     {"domain", Stage::Domain},     {"kernel", Stage::Compute}};
// Unity pragmas that change how Unity builds a shader, and what kiln does instead.
constexpr std::pair<std::string_view, std::string_view> kUnityIgnoredPragmas[] = {
    {"target", "kiln compiles for the targets the pack names, the SPIR-V for Vulkan 1.1 (SPIR-V 1.3)"},
    {"require", "kiln compiles for the targets the pack names; a feature the code uses is checked by spirv-val"},
    {"exclude_renderers", "every pass is built for the pack's targets: give the pass \"targets\" of its own"},
    {"only_renderers", "every pass is built for the pack's targets: give the pass \"targets\" of its own"},
    {"skip_variants", "nothing is stripped by it: write the rule as a pack constraint"},
    {"instancing_options", "instancing is the INSTANCING_ON keyword of #pragma multi_compile_instancing"},
    {"surface", "surface shaders are Unity's code generator: write the vertex and fragment functions"},
    {"enable_d3d11_debug_symbols", "use kiln build -g"},
    {"hardware_tier_variants", "tiers are keywords: declare them with #pragma multi_compile"},
    {"editor_sync_compilation", "kiln compiles every variant the pack keeps before the pack is written"},
};

struct Word {
  std::string_view text;
  int column;  // 1-based, in the original line
};

std::vector<Word> split_words(std::string_view line, int first_column) {
  std::vector<Word> words;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) words.push_back({line.substr(start, i - start), first_column + static_cast<int>(start)});
  }
  return words;
}

struct Directive {
  int line;
  int column;              // of '#'
  std::string_view name;   // "include", "pragma", ...
  std::string_view rest;   // after the name
  int rest_column;
};

std::optional<Directive> directive_of(const std::string& line, int line_number) {
  size_t hash = line.find_first_not_of(" \t");
  if (hash == std::string::npos || line[hash] != '#') return std::nullopt;
  size_t name_start = line.find_first_not_of(" \t", hash + 1);
  if (name_start == std::string::npos) return std::nullopt;
  size_t name_end = name_start;
  while (name_end < line.size() && std::isalpha(static_cast<unsigned char>(line[name_end]))) ++name_end;
  Directive d;
  d.line = line_number;
  d.column = static_cast<int>(hash) + 1;
  d.name = std::string_view(line).substr(name_start, name_end - name_start);
  d.rest = std::string_view(line).substr(name_end);
  d.rest_column = static_cast<int>(name_end) + 1;
  return d;
}

bool has_pragma_once(const std::vector<std::string>& lines) {
  for (size_t i = 0; i < lines.size(); ++i) {
    auto d = directive_of(lines[i], static_cast<int>(i + 1));
    if (!d || d->name != "pragma") continue;
    auto words = split_words(d->rest, 0);
    if (words.size() == 1 && words[0].text == "once") return true;
  }
  return false;
}

bool has_include_guard(const std::vector<std::string>& lines) {
  std::vector<Directive> directives;
  for (size_t i = 0; i < lines.size() && directives.size() < 2; ++i) {
    auto d = directive_of(lines[i], static_cast<int>(i + 1));
    if (!d) continue;
    if (d->name == "pragma" && split_words(d->rest, 0).size() == 1 && split_words(d->rest, 0)[0].text == "once")
      return true;
    directives.push_back(*d);
  }
  if (directives.size() < 2 || directives[0].name != "ifndef" || directives[1].name != "define") return false;
  auto guard = split_words(directives[0].rest, 0);
  auto defined = split_words(directives[1].rest, 0);
  return !guard.empty() && !defined.empty() && guard[0].text == defined[0].text;
}

struct Scanner {
  const IncludeRoots& roots;
  const ReadLimits& limits;
  SourceSet& sources;
  DiagnosticSink& sink;
  PassDeclarations& result;
  std::map<std::string, SourceLocation> declared;  // keyword -> where
  std::vector<std::filesystem::path> chain;
  std::set<std::filesystem::path> visited;
  bool ok = true;

  void error(DiagId id, SourceLocation at, std::string message, std::vector<std::string> notes = {}) {
    ok = false;
    sink.report(id, std::move(at), std::move(message), std::move(notes));
  }

  const SourceFile* load(const std::filesystem::path& canonical, const SourceLocation& referenced_from) {
    if (const SourceFile* known = sources.find(canonical)) return known;
    auto text = read_text_file(canonical, limits, sink, referenced_from);
    if (!text) {
      ok = false;
      return nullptr;
    }
    SourceFile file{canonical, std::move(*text), false};
    std::vector<std::string> lines = code_lines(file.text);
    file.pragma_once = has_pragma_once(lines);
    file.guarded = file.pragma_once || has_include_guard(lines);
    return &sources.files.emplace(canonical, std::move(file)).first->second;
  }

  void add_group(KeywordGroup group) {
    for (const std::string& keyword : group.values) {
      if (keyword.empty()) continue;
      auto [it, inserted] = declared.emplace(keyword, group.declared_at);
      if (!inserted) {
        const SourceLocation& first = it->second;
        error(DiagId::KeywordInTwoGroups, group.declared_at,
              "keyword '" + keyword + "' is already declared in another keyword group",
              {"first declared at " + first.path + ":" + std::to_string(first.line)});
      }
    }
    result.groups.push_back(std::move(group));
  }

  void visit(const SourceFile& file) {
    chain.push_back(file.path);
    visited.insert(file.path);
    result.files.push_back(file.path);
    const std::string shown = display_path(file.path);
    std::vector<std::string> lines = code_lines(file.text);
    // Conditionals must close in the file that opens them (as in C). Checked here, once per file, so that
    // an unclosed #if is reported at its own line, not at the end of every variant's text.
    std::vector<SourceLocation> open_conditionals;
    for (size_t i = 0; i < lines.size(); ++i) {
      auto directive = directive_of(lines[i], static_cast<int>(i + 1));
      if (!directive) continue;
      SourceLocation at{shown, directive->line, directive->column};
      const std::string_view name = directive->name;
      if (name == "if" || name == "ifdef" || name == "ifndef") {
        open_conditionals.push_back(at);
      } else if (name == "elif" || name == "else" || name == "endif") {
        if (open_conditionals.empty()) error(DiagId::PreprocessorError, at, "#" + std::string(name) + " without #if");
        else if (name == "endif") open_conditionals.pop_back();
      } else if (name == "pragma") {
        auto parsed = parse_keyword_pragma(directive->rest, at, directive->rest_column);
        if (!parsed) {
          sink.report(std::move(parsed).error());
          ok = false;
        } else if (*parsed) {
          add_group(std::move(**parsed));
        } else {
          unity_pragma(*directive, at, file);
        }
      } else if (directive->name == "include") {
        include(*directive, at, file);
      }
    }
    for (const SourceLocation& at : open_conditionals)
      error(DiagId::PreprocessorError, at, "#if without #endif in this file (a conditional closes in the file that opens it)");
    chain.pop_back();
  }

  // Unity's pragmas that are not keyword pragmas: a stage's entry point is recorded (the first of each stage); the
  // others that change how Unity builds a shader are a note, once a line, so that nothing is silently ignored.
  void unity_pragma(const Directive& directive, const SourceLocation& at, const SourceFile& file) {
    const std::vector<Word> words = split_words(directive.rest, directive.rest_column);
    if (words.empty()) return;
    const std::string_view pragma = words[0].text;
    for (const auto& [name, stage] : kUnityStagePragmas) {
      if (pragma != name) continue;
      if (words.size() >= 2 && is_identifier(words[1].text) && !result.stage_pragmas[static_cast<size_t>(stage)])
        result.stage_pragmas[static_cast<size_t>(stage)] =
            PassDeclarations::StagePragma{std::string(words[1].text), SourceLocation{at.path, at.line, words[1].column}};
      return;
    }
    for (const auto& [name, why] : kUnityIgnoredPragmas) {
      if (pragma != name || !sources.noted.emplace(file.path, at.line).second) continue;
      Diagnostic d;
      d.id = DiagId::UnityPragma;
      d.severity = Severity::Note;
      d.location = SourceLocation{at.path, at.line, words[0].column};
      d.message = "'#pragma " + std::string(pragma) + "' is Unity's: kiln does not act on it (" + std::string(why) + ")";
      sink.report(std::move(d));
      return;
    }
  }

  void include(const Directive& directive, SourceLocation at, const SourceFile& from) {
    std::string_view rest = directive.rest;
    size_t open = rest.find_first_not_of(" \t");
    char closer = open == std::string_view::npos ? 0 : rest[open] == '"' ? '"' : rest[open] == '<' ? '>' : 0;
    size_t close = closer ? rest.find(closer, open + 1) : std::string_view::npos;
    if (close == std::string_view::npos) {
      error(DiagId::IncludeSyntax, at, "expected #include \"file\" or #include <file>");
      return;
    }
    std::string_view name = rest.substr(open + 1, close - open - 1);
    at.column = directive.rest_column + static_cast<int>(open);
    Result<ResolvedInclude, Diagnostic> found = resolve_include(name, from.path, roots);
    if (!found) {
      error(found.error().id, at, found.error().message, found.error().notes);
      return;
    }
    const ResolvedInclude& resolved = *found;
    sources.files.at(from.path).includes.emplace(std::string(name), resolved.path);
    sources.watched.insert(resolved.watch.begin(), resolved.watch.end());
    if (std::find(chain.begin(), chain.end(), resolved.path) != chain.end()) {
      const SourceFile* target = sources.find(resolved.path);
      if (target && target->guarded) return;  // the guard ends the recursion at preprocessing time
      std::vector<std::string> notes;
      auto start = std::find(chain.begin(), chain.end(), resolved.path);
      for (auto it = start; it != chain.end(); ++it) {
        auto next = std::next(it) == chain.end() ? resolved.path : *std::next(it);
        notes.push_back(display_path(*it) + " includes " + display_path(next));
      }
      notes.push_back("add '#pragma once' or an include guard, or remove the #include");
      error(DiagId::IncludeCycle, at, "#include cycle: '" + display_path(resolved.path) + "' includes itself", notes);
      return;
    }
    if (visited.count(resolved.path)) return;
    if (static_cast<int>(chain.size()) >= kMaxIncludeDepth) {
      error(DiagId::IncludeTooDeep, at, "#include nesting is deeper than " + std::to_string(kMaxIncludeDepth));
      return;
    }
    if (const SourceFile* target = load(resolved.path, at)) visit(*target);
  }
};

}  // namespace

Result<std::optional<KeywordGroup>, Diagnostic> parse_keyword_pragma(std::string_view body, const SourceLocation& at,
                                                                    int body_column) {
  using Parsed = Result<std::optional<KeywordGroup>, Diagnostic>;
  std::vector<Word> words = split_words(body, body_column);
  if (words.empty()) return Parsed(std::nullopt);
  std::string_view pragma = words[0].text;
  KeywordGroup group;
  group.pragma = std::string(pragma);
  group.declared_at = at;
  auto fail = [&](DiagId id, int column, std::string message) -> Parsed {
    return failure(Diagnostic{id, diagnostic_info(id).severity, SourceLocation{at.path, at.line, column}, std::move(message), {}});
  };
  // What each spelling means: common/keyword_pragmas.hpp.
  const std::optional<KeywordPragma> kind = classify_keyword_pragma(pragma);
  if (!kind) return Parsed(std::nullopt);  // some other pragma (vertex, target, ...): not ours
  group.material_feature = kind->kind->material_feature;
  group.local = kind->local;
  group.stages = kind->stages;
  if (!kind->kind->implied_values.empty()) {
    if (words.size() > 1) return fail(DiagId::PragmaSyntax, words[1].column, group.pragma + " takes no keywords");
    group.values.assign(kind->kind->implied_values.begin(), kind->kind->implied_values.end());
    return Parsed(std::move(group));
  }
  if (!kind->known_suffix) {
    return fail(DiagId::PragmaSyntax, words[0].column,
                "unsupported keyword pragma '" + std::string(pragma) +
                    "' (expected multi_compile, shader_feature, " + keyword_kind_list({}, true) +
                    ", optionally _local and _vertex/_fragment)");
  }
  if (words.size() == 1) return fail(DiagId::PragmaSyntax, words[0].column, "'" + group.pragma + "' declares no keywords");
  for (size_t i = 1; i < words.size(); ++i) {
    std::string_view word = words[i].text;
    bool none = word.find_first_not_of('_') == std::string_view::npos;
    if (!none && !is_identifier(word))
      return fail(DiagId::InvalidKeywordName, words[i].column, "'" + std::string(word) + "' is not a valid keyword name");
    std::string value = none ? "" : std::string(word);
    if (group.index_of(value) >= 0)
      return fail(DiagId::PragmaSyntax, words[i].column,
                  "'" + std::string(word) + "' appears twice in one keyword group");
    group.values.push_back(value);
  }
  // Unity's rule: a lone shader_feature keyword may be off; a lone multi_compile keyword is always on. A lone folded
  // keyword may be off too: a bool that is always true chooses nothing.
  if ((group.material_feature || is_folded(group.kind())) && group.values.size() == 1 && !group.values[0].empty())
    group.values.insert(group.values.begin(), "");
  return Parsed(std::move(group));
}

std::optional<PassDeclarations> scan_declarations(const std::filesystem::path& entry, const IncludeRoots& roots,
                                                  const ReadLimits& limits, SourceSet& sources, DiagnosticSink& sink) {
  PassDeclarations result;
  std::error_code ec;
  result.entry = std::filesystem::weakly_canonical(entry, ec);
  if (ec) result.entry = entry;
  Scanner scanner{roots, limits, sources, sink, result, {}, {}, {}, true};
  const SourceFile* file = scanner.load(result.entry, SourceLocation{display_path(entry), 0, 0});
  if (!file) return std::nullopt;
  scanner.visit(*file);
  if (!scanner.ok) return std::nullopt;
  return result;
}

std::optional<PassDeclarations> scan_pass_declarations(const PassDefinition& pass, const IncludeRoots& roots,
                                                       const ReadLimits& limits, SourceSet& sources, DiagnosticSink& sink) {
  std::optional<PassDeclarations> merged;
  std::vector<std::filesystem::path> scanned;  // as the pass names them
  for (Stage stage : kAllStages) {
    const std::filesystem::path& file = pass.stage_sources[static_cast<size_t>(stage)];
    if (pass.entry_points[static_cast<size_t>(stage)].empty() ||
        std::find(scanned.begin(), scanned.end(), file) != scanned.end())
      continue;
    scanned.push_back(file);
    StageMask using_file = 0;  // the stages this file is the entry of
    for (Stage s : kAllStages)
      if (!pass.entry_points[static_cast<size_t>(s)].empty() && pass.stage_sources[static_cast<size_t>(s)] == file)
        using_file |= stage_bit(s);
    auto found = scan_declarations(file, roots, limits, sources, sink);
    if (!found) return std::nullopt;
    for (Stage s : kAllStages)
      if (using_file & stage_bit(s)) found->stage_entry[static_cast<size_t>(s)] = found->entry;
    if (!merged) {
      merged = std::move(*found);
      // With one source the groups keep their pragma's stages; with several, each file's reach the stages using it.
      if (using_file != [&] {
            StageMask all = 0;
            for (Stage s : kAllStages)
              if (!pass.entry_points[static_cast<size_t>(s)].empty()) all |= stage_bit(s);
            return all;
          }())
        for (KeywordGroup& g : merged->groups) g.stages &= using_file;
      continue;
    }
    for (const std::filesystem::path& f : found->files)
      if (std::find(merged->files.begin(), merged->files.end(), f) == merged->files.end()) merged->files.push_back(f);
    for (Stage s : kAllStages)
      if (using_file & stage_bit(s)) merged->stage_entry[static_cast<size_t>(s)] = found->entry;
    for (KeywordGroup& g : found->groups) {
      g.stages &= using_file;
      auto same = std::find_if(merged->groups.begin(), merged->groups.end(), [&](const KeywordGroup& m) {
        return m.pragma == g.pragma && m.values == g.values;
      });
      if (same != merged->groups.end()) same->stages |= g.stages;
      else merged->groups.push_back(std::move(g));
    }
  }
  return merged;
}

bool apply_stage_pragmas(PassDefinition& pass, const IncludeRoots& roots, const ReadLimits& limits, SourceSet& sources,
                         DiagnosticSink& sink) {
  const bool named = std::any_of(pass.entry_points.begin(), pass.entry_points.end(), [](const std::string& e) { return !e.empty(); });
  if (pass.source.empty()) return named;  // every stage names its own file: the definition checked it has stages
  // The pass's own source (where Unity writes its pragmas); a stage of a file of its own keeps what the pack says.
  std::optional<PassDeclarations> scanned = scan_declarations(pass.source, roots, limits, sources, sink);
  if (!scanned) return false;
  bool any = false;
  for (Stage stage : kAllStages) {
    const auto& pragma = scanned->stage_pragmas[static_cast<size_t>(stage)];
    if (!pragma) continue;
    any = true;
    std::string& entry = pass.entry_points[static_cast<size_t>(stage)];
    if (!named) {
      entry = pragma->entry;
      pass.stage_sources[static_cast<size_t>(stage)] = pass.source;
    } else if ((pass.default_entries & stage_bit(stage)) && pass.stage_sources[static_cast<size_t>(stage)] == pass.source) {
      entry = pragma->entry;  // the default "main" yields to the entry point the source names
    } else if (!entry.empty() && pass.stage_sources[static_cast<size_t>(stage)] == pass.source && entry != pragma->entry) {
      // (A stage the pack does not build is its choice: `kiln compile -S frag` of a file that names both.)
      sink.report(DiagId::StagePragma, pragma->at,
                  "'#pragma " + std::string(std::find_if(std::begin(kUnityStagePragmas), std::end(kUnityStagePragmas),
                                                         [&](const auto& p) { return p.second == stage; })->first) +
                      " " + pragma->entry + "' disagrees with pass '" + pass.name + "' of the pack, whose " +
                      std::string(stage_name(stage)) + " stage is '" + entry + "': the pack's stages are used",
                  {"remove the pass's \"stages\" to take the pragmas' entry points, or make them agree"});
    }
  }
  if (!named && !any) {
    Diagnostic d;
    d.id = DiagId::StagePragma;
    d.severity = Severity::Error;
    d.location = pass.defined_at;
    d.message = "pass '" + pass.name + "' has no \"stages\" and its source names none with '#pragma vertex NAME' / "
                "'#pragma fragment NAME'";
    d.notes = {"give the pass \"stages\": {\"vertex\": \"Entry\", \"fragment\": \"Entry\"}, or the pragmas in its source"};
    sink.report(std::move(d));
    return false;
  }
  return true;
}

}  // namespace kiln
