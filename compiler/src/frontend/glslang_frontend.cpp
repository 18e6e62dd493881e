// SPDX-License-Identifier: Apache-2.0
#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>
#include <glslang/build_info.h>

#include <algorithm>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <regex>
#include <set>
#include <sstream>

#include "common/target_environment.hpp"
#include "frontend/hlsl_compat.hpp"
#include "frontend/debug_source.hpp"
#include "frontend/dxc_semantics.hpp"
#include "frontend/nonuniform.hpp"
#include "frontend/frontend.hpp"
#include "common/hash.hpp"
#include "common/line_tokens.hpp"
#include "frontend/glslang_bindings.hpp"
#include "frontend/glslang_literals.hpp"
#include "frontend/glslang_shader.hpp"
#include "frontend/interface_semantics.hpp"
#include "frontend/module_limits.hpp"

namespace kiln {
namespace {

void initialize_glslang_once() {
  static std::once_flag once;
  std::call_once(once, [] { glslang::InitializeProcess(); });
}

EShLanguage to_glslang(Stage stage) {
  switch (stage) {
    case Stage::Vertex: return EShLangVertex;
    case Stage::Fragment: return EShLangFragment;
    case Stage::Compute: return EShLangCompute;
    case Stage::Geometry: return EShLangGeometry;
    case Stage::Hull: return EShLangTessControl;
    case Stage::Domain: return EShLangTessEvaluation;
  }
  return EShLangFragment;
}

// 16-bit types on: `real` in shaderlib becomes float16_t under _HALF_PRECISION.
constexpr auto kMessages = static_cast<EShMessages>(EShMsgReadHlsl | EShMsgSpvRules | EShMsgVulkanRules |
                                                    EShMsgHlslEnable16BitTypes);

void configure(glslang::TShader& shader, Stage stage) {
  shader.setEnvInput(glslang::EShSourceHlsl, to_glslang(stage), glslang::EShClientVulkan, 100);
  constexpr TargetEnvironment env = kTargetEnvironment;  // glslang encodes versions as Vulkan's and SPIR-V's headers do
  shader.setEnvClient(glslang::EShClientVulkan,
                      static_cast<glslang::EShTargetClientVersion>((env.vulkan_major << 22) | (env.vulkan_minor << 12)));
  shader.setEnvTarget(glslang::EShTargetSpv,
                      static_cast<glslang::EShTargetLanguageVersion>((env.spirv_major << 16) | (env.spirv_minor << 8)));
}

// Whether `line` is exactly a `#pragma once` directive (spaces, tabs and a trailing comment allowed).
bool is_pragma_once(std::string_view line) {
  auto skip_blanks = [&] {
    while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
  };
  auto take = [&](std::string_view word) {
    if (!line.starts_with(word)) return false;
    line.remove_prefix(word.size());
    return true;
  };
  skip_blanks();
  if (!take("#")) return false;
  skip_blanks();
  if (!take("pragma") || line.empty() || (line.front() != ' ' && line.front() != '\t')) return false;
  skip_blanks();
  if (!take("once")) return false;
  skip_blanks();
  return line.empty() || line == "\r" || line.starts_with("//") || line.starts_with("/*");
}

// kiln's includer implements `#pragma once`; glslang does not, and warns "'#pragma once' : not implemented"
// for every variant. The directive's lines are blanked (line numbers unchanged) before glslang sees the text.
// Only lines holding "once" are looked at: this runs on every stage source's entry file.
std::optional<std::string> without_pragma_once(std::string_view text) {
  std::optional<std::string> out;
  for (size_t at = text.find("once"); at != std::string_view::npos; at = text.find("once", at + 4)) {
    const size_t begin = text.rfind('\n', at) == std::string_view::npos ? 0 : text.rfind('\n', at) + 1;
    const size_t end = std::min(text.find('\n', at), text.size());
    if (!is_pragma_once(text.substr(begin, end - begin))) continue;
    if (!out) out.emplace(text);
    std::fill(out->begin() + begin, out->begin() + end, ' ');
  }
  return out;
}

// glslang's preprocess-only mode rejects `#include "x"` on a last line without a newline ("expected newline after
// header name"), which its full compile, glslangValidator and glslc accept: a file that does not end in a newline
// is given one (`served`: the text as rewritten so far, or null for `original` itself).
void with_final_newline(std::shared_ptr<const std::string>& served, std::string_view original) {
  const std::string_view text = served ? std::string_view(*served) : original;
  if (text.empty() || text.back() == '\n') return;
  served = std::make_shared<const std::string>(std::string(text) + "\n");
}

// protect_literals is a pure function of a file's text, and a build preprocesses the same few files for
// every stage source: each distinct text is rewritten once. Shared by the preprocessing threads.
class ProtectedTexts {
 public:
  // The text glslang is given: `text` itself (nullptr) or its rewritten form.
  std::shared_ptr<const std::string> get(std::string_view text) {
    const Hash128 key = hash128(text);
    {
      std::lock_guard lock(mutex_);
      if (auto it = texts_.find(key); it != texts_.end()) return it->second;
    }
    std::optional<std::string> rewritten = protect_literals(text);
    auto shared = rewritten ? std::make_shared<const std::string>(std::move(*rewritten)) : nullptr;
    std::lock_guard lock(mutex_);
    if (texts_.size() >= kMaxTexts) texts_.clear();  // a bound for long-lived front ends; a build needs far fewer
    texts_.emplace(key, shared);
    return shared;
  }

 private:
  static constexpr size_t kMaxTexts = 4096;
  std::mutex mutex_;
  std::map<Hash128, std::shared_ptr<const std::string>> texts_;
};

class Includer final : public glslang::TShader::Includer {
 public:
  Includer(const IncludeSource* source, std::string entry_name, ProtectedTexts& protected_texts)
      : source_(source), entry_name_(std::move(entry_name)), protected_texts_(protected_texts) {}

  IncludeResult* includeLocal(const char* requested, const char* from, size_t depth) override {
    if (!source_) return failure("#include is not available here");
    // Cycles were rejected by the declaration scan; this bound only protects against macro tricks.
    if (depth > 64) return failure("#include nesting is deeper than 64");
    // Files that include each other twice without guards multiply: 24 of them are 2^24 inclusions.
    if (++inclusions_ > kMaxInclusions)
      return failure("more than " + std::to_string(kMaxInclusions) +
                     " #include expansions in one stage source (files included again and again without an include guard?)");
    const std::string from_name = (from && *from) ? from : entry_name_;
    Result<IncludeSource::Found> resolved = source_->resolve(requested, from_name);
    if (!resolved) return failure(resolved.error().message);
    const IncludeSource::Found& found = *resolved;
    included_bytes_ += found.text.size();
    if (included_bytes_ > kMaxIncludedBytes)
      return failure("more than " + std::to_string(kMaxIncludedBytes >> 20) + " MiB of #include text in one stage source");
    if (found.once && !once_seen_.insert(found.name).second)
      return new IncludeResult(found.name, "", 0, nullptr);  // #pragma once: second inclusion is empty
    std::shared_ptr<const std::string> served;
    if (found.once) {
      if (auto blanked = without_pragma_once(found.text)) served = std::make_shared<const std::string>(std::move(*blanked));
    }
    if (auto rewritten = protected_texts_.get(served ? std::string_view(*served) : std::string_view(found.text)))
      served = std::move(rewritten);
    with_final_newline(served, found.text);
    if (served) {
      auto* owner = new Text(std::move(served));  // before the result reads its data: argument order is unspecified
      return new IncludeResult(found.name, (*owner)->data(), (*owner)->size(), owner);
    }
    return new IncludeResult(found.name, found.text.data(), found.text.size(), nullptr);
  }
  IncludeResult* includeSystem(const char* requested, const char* from, size_t depth) override {
    return includeLocal(requested, from, depth);
  }
  void releaseInclude(IncludeResult* result) override {
    if (result && result->userData) delete static_cast<Text*>(result->userData);
    delete result;
  }

 private:
  using Text = std::shared_ptr<const std::string>;  // what an IncludeResult's userData owns
  IncludeResult* failure(const std::string& message) {
    auto* text = new Text(std::make_shared<const std::string>(message));
    return new IncludeResult("", (*text)->data(), (*text)->size(), text);
  }
  // Far above real libraries (kiln's own stage sources make under 100 inclusions of under 1 MiB) and far
  // below what exhausts memory or time.
  static constexpr size_t kMaxInclusions = 20000;
  static constexpr size_t kMaxIncludedBytes = size_t{256} << 20;
  const IncludeSource* source_;
  std::string entry_name_;
  ProtectedTexts& protected_texts_;
  std::set<std::string> once_seen_;
  size_t inclusions_ = 0;
  size_t included_bytes_ = 0;
};

class GlslangFrontend final : public Frontend {
 public:
  GlslangFrontend() { initialize_glslang_once(); }

  std::string name() const override { return "glslang"; }
  std::string version() const override {
    return std::to_string(GLSLANG_VERSION_MAJOR) + "." + std::to_string(GLSLANG_VERSION_MINOR) + "." +
           std::to_string(GLSLANG_VERSION_PATCH) + GLSLANG_VERSION_FLAVOR;
  }

  PreprocessResult preprocess(const PreprocessRequest& request) override {
    PreprocessResult result;
    glslang::TShader shader(to_glslang(request.stage));
    std::shared_ptr<const std::string> entry_served;
    if (auto blanked = without_pragma_once(request.entry_text)) entry_served = std::make_shared<const std::string>(std::move(*blanked));
    if (auto rewritten = protected_texts_.get(entry_served ? std::string_view(*entry_served) : request.entry_text))
      entry_served = std::move(rewritten);
    with_final_newline(entry_served, request.entry_text);
    const std::string_view entry = entry_served ? std::string_view(*entry_served) : request.entry_text;
    const char* text = entry.data();
    const int length = static_cast<int>(entry.size());
    const char* name = request.entry_name.c_str();
    shader.setStringsWithLengthsAndNames(&text, &length, &name, 1);
    std::string preamble;
    for (const std::string& define : request.defines) {
      const size_t equals = define.find('=');
      preamble += equals == std::string::npos ? "#define " + define + " 1\n"
                                              : "#define " + define.substr(0, equals) + " " + define.substr(equals + 1) + "\n";
    }
    shader.setPreamble(preamble.c_str());
    configure(shader, request.stage);
    Includer includer(request.includes, request.entry_name, protected_texts_);
    result.ok = shader.preprocess(GetDefaultResources(), 100, ENoProfile, false, false, kMessages, &result.text, includer);
    if (auto restored = restore_literals(result.text)) result.text = std::move(*restored);
    result.messages = parse_frontend_log(shader.getInfoLog(), request.entry_name);
    if (!result.ok && result.messages.empty())
      result.messages.push_back({Severity::Error, request.entry_name, 0, "preprocessing failed"});
    return result;
  }

  CompileResult compile(const CompileRequest& request) override {
    CompileResult result;
    // DXC's meanings that glslang 12 would change (frontend/hlsl_compat.hpp).
    std::optional<std::string> compatible = rewrite_attribute_lists(request.source);
    if (auto rewritten = rewrite_push_constants(compatible ? std::string_view(*compatible) : std::string_view(request.source)))
      compatible = std::move(rewritten);
    std::optional<MemberOffsets> member_offsets =
        strip_member_offsets(compatible ? std::string_view(*compatible) : std::string_view(request.source));
    if (member_offsets) compatible = member_offsets->text;
    if (auto rewritten = rewrite_hlsl2021_intrinsics(compatible ? std::string_view(*compatible) : std::string_view(request.source)))
      compatible = std::move(rewritten);
    if (auto rewritten = rewrite_literal_swizzles(compatible ? std::string_view(*compatible) : std::string_view(request.source)))
      compatible = std::move(rewritten);
    if (auto rewritten = rewrite_enums(compatible ? std::string_view(*compatible) : std::string_view(request.source)))
      compatible = std::move(rewritten);
    if (auto rewritten = rewrite_byte_address_atomics(compatible ? std::string_view(*compatible) : std::string_view(request.source)))
      compatible = std::move(rewritten);
    const auto compare_store = rewrite_compare_store(compatible ? std::string_view(*compatible) : std::string_view(request.source));
    if (compare_store) compatible = *compare_store;
    const auto reserved = rewrite_reserved_names(compatible ? std::string_view(*compatible) : std::string_view(request.source));
    if (reserved) compatible = *reserved;
    const auto nonuniform = rewrite_nonuniform_index(compatible ? std::string_view(*compatible) : std::string_view(request.source));
    if (nonuniform) compatible = *nonuniform;
    const std::string_view source = compatible ? std::string_view(*compatible) : std::string_view(request.source);
    // With SV_ViewID or SV_ShadingRate, the semantics in the SPIR-V, for restore_builtin_semantics.
    const bool builtin_semantics = names_builtin_semantics(source);
    const std::unique_ptr<glslang::TShader> made = make_glslang_shader(to_glslang(request.stage), builtin_semantics);
    glslang::TShader& shader = *made;
    const char* text = source.data();
    const int length = static_cast<int>(source.size());
    const char* name = request.source_name.c_str();
    shader.setStringsWithLengthsAndNames(&text, &length, &name, 1);
    shader.setEntryPoint(request.entry_point.c_str());
    configure(shader, request.stage);
    std::string preamble;
    if (nonuniform) preamble += kNonUniformMarkerDefinition;
    if (compare_store) preamble += kCompareStoreOriginalDeclaration;
    if (!preamble.empty()) shader.setPreamble(preamble.c_str());  // lives until the parse below
    if (request.debug_info) shader.setDebugInfo(true);
    const auto rules = request.debug_info ? static_cast<EShMessages>(kMessages | EShMsgDebugInfo) : kMessages;
    bool parsed = shader.parse(GetDefaultResources(), 100, false, rules);
    result.messages = parse_frontend_log(shader.getInfoLog(), request.source_name, source);
    if (!parsed) return result;
    // glslang only warns about a missing entry point; kiln makes it an error.
    if (shader.getIntermediate()->getNumEntryPoints() == 0) {
      result.missing_entry_point = true;
      return result;
    }
    glslang::TProgram program;
    program.addShader(&shader);
    if (!program.link(rules)) {
      auto link = parse_frontend_log(program.getInfoLog(), request.source_name);
      result.messages.insert(result.messages.end(), link.begin(), link.end());
      return result;
    }
    if (Result<void> mapped = map_glslang_bindings(program, to_glslang(request.stage), request.bindings, source); !mapped) {
      const std::string& error = mapped.error().message;
      auto messages = parse_frontend_log(error, request.source_name);
      if (messages.empty()) messages.push_back({Severity::Error, request.source_name, 0, error});
      result.messages.insert(result.messages.end(), messages.begin(), messages.end());
      return result;
    }
    glslang::SpvOptions options;
    options.disableOptimizer = true;  // kiln runs legalization and optimization itself (stage 5)
    options.validate = false;
    if (request.debug_info) {
      // OpSource with the source text, OpLine and names: what glslangValidator -g writes. Not glslang 12's
      // non-semantic shader debug info (-gVS): its modules fail validation (OpVariable after debug instructions)
      // and legalization (an OpString one word short).
      options.generateDebugInfo = true;
      without_lexical_scopes(*program.getIntermediate(to_glslang(request.stage)));
    }
    spv::SpvBuildLogger logger;
    glslang::GlslangToSpv(*program.getIntermediate(to_glslang(request.stage)), result.spirv, &logger, &options);
    if (request.debug_info) keep_original_sources(result.spirv, request.debug_sources);
    // DXC's meanings that glslang 12 would change without a word (frontend/dxc_semantics.hpp, nonuniform.hpp).
    Result<void> edited = make_arrays_unbounded(result.spirv, unbounded_resource_arrays(source));
    if (member_offsets) {
      const std::vector<UnhonouredOffset> unhonoured = write_member_offsets(result.spirv, member_offsets->stated);
      for (const UnhonouredOffset& refused : unhonoured) {
        const StatedOffset& offset = member_offsets->stated[refused.stated];
        // Quoting the word first, as glslang does, lets the driver find its column.
        FrontendMessage& message = result.messages.emplace_back(located_in_source(source, offset.at, request.source_name,
            "'offset' : [[vk::offset(" + std::to_string(offset.offset) + ")]] on '" + offset.record + "." + offset.member +
            "' cannot be honoured: " + refused.reason + " (order and pad the members instead)"));
        message.column = 0;  // the preprocessed text's spacing is not the file's: the driver finds the quoted word
      }
      if (!unhonoured.empty()) return result;
    }
    if (edited && builtin_semantics) edited = restore_builtin_semantics(result.spirv, explicit_locations(source));
    if (edited)
      edited = attach_interface_semantics(result.spirv, interface_semantics(*program.getIntermediate(to_glslang(request.stage))));
    if (!edited) {
      result.messages.push_back({Severity::Error, request.source_name, 0, edited.error().message});
      return result;
    }
    // spirv-val reports two stated locations that collide at the entry point, with no line: located here.
    if (auto conflict = conflicting_location(result.spirv))
      if (auto located = locate_location_conflict(*conflict, source, request.source_name)) {
        result.messages.push_back(std::move(*located));
        return result;
      }
    if (nonuniform) decorate_nonuniform(result.spirv);
    if (reserved) restore_reserved_names(result.spirv);
    if (std::string messages = logger.getAllMessages(); !messages.empty()) {
      std::istringstream lines(messages);
      for (std::string line; std::getline(lines, line);)
        if (!line.empty()) result.messages.push_back({Severity::Warning, request.source_name, 0, line});
    }
    result.ok = !result.spirv.empty();
    return result;
  }

 private:
  ProtectedTexts protected_texts_;
};

}  // namespace

std::unique_ptr<Frontend> make_glslang_frontend() { return std::make_unique<GlslangFrontend>(); }

namespace {

// The line of `text` that its #line directives number `line` of `path` (the first such), or nothing.
std::optional<std::string_view> line_numbered(std::string_view text, const std::string& path, int line) {
  std::string file;  // the entry's name until a #line names another: glslang's, the caller's path
  bool named = false;
  int number = 1;
  for (size_t at = 0; at < text.size();) {
    const size_t end = std::min(text.find('\n', at), text.size());
    std::string_view row = text.substr(at, end - at);
    at = end + 1;
    std::string_view rest = row.substr(std::min(row.find_first_not_of(" \t"), row.size()));
    if (rest.starts_with("#line")) {
      rest.remove_prefix(5);
      rest.remove_prefix(std::min(rest.find_first_not_of(" \t"), rest.size()));
      size_t digits = 0;
      while (digits < rest.size() && digits < 9 && std::isdigit(static_cast<unsigned char>(rest[digits]))) ++digits;
      if (digits > 0) {
        number = std::stoi(std::string(rest.substr(0, digits)));
        const size_t open = rest.find('"', digits);
        const size_t close = open == std::string_view::npos ? open : rest.find('"', open + 1);
        if (close != std::string_view::npos) {
          file = std::string(rest.substr(open + 1, close - open - 1));
          named = true;
        }
        continue;
      }
    }
    if (number == line && (named ? file == path : true)) return row;
    ++number;
  }
  return std::nullopt;
}

// glslang's column (1-based) in the parsed line as its token and which of the line's tokens of that text it is.
void name_token(FrontendMessage& message, std::string_view parsed, int column) {
  const std::optional<std::string_view> row = line_numbered(parsed, message.path, message.line);
  if (!row || column < 1) return;
  const size_t at = static_cast<size_t>(column - 1);
  const std::vector<std::pair<size_t, size_t>> tokens = line_tokens(*row);
  auto text = [&](size_t t) { return row->substr(tokens[t].first, tokens[t].second - tokens[t].first); };
  for (size_t t = 0; t < tokens.size(); ++t) {
    if (at < tokens[t].first) return;  // in the spaces before a token
    if (at >= tokens[t].second) continue;
    message.token = std::string(text(t));
    message.occurrence = 0;
    for (size_t before = 0; before <= t; ++before)
      if (text(before) == message.token) ++message.occurrence;
    return;
  }
}

}  // namespace

std::vector<FrontendMessage> parse_frontend_log(std::string_view log, std::string_view fallback_path, std::string_view parsed) {
  static const std::regex located(R"(^(ERROR|WARNING|INTERNAL ERROR|UNIMPLEMENTED): (.*?):(\d+): (.*)$)");
  static const std::regex plain(R"(^(ERROR|WARNING|INTERNAL ERROR|UNIMPLEMENTED): (.*)$)");
  static const std::regex summary(R"(^\d+ compilation errors\.|^Linking .*stage:$|^$)");
  // The HLSL grammar's own report when no rule matched: "S.hlsl(2): error at column 38, HLSL parsing failed."
  static const std::regex grammar(R"(^(.*)\((\d+)\): error at column (\d+), (.*?)\.?$)");
  std::vector<FrontendMessage> messages;
  std::istringstream lines{std::string(log)};
  for (std::string line; std::getline(lines, line);) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    std::smatch m;
    if (std::regex_match(line, m, located)) {
      Severity severity = m[1] == "WARNING" ? Severity::Warning : Severity::Error;
      std::string text = m[4];
      // glslang quotes the offending token first; with no token ("'' : missing #endif") that says nothing.
      if (text.starts_with("'' : ")) text.erase(0, 5);
      // Source string -1 is glslang's preamble: the #define lines of the pass's defines (-D, the pack's
      // "defines") and keywords. It is no file.
      if (m[2] == "-1") {
        messages.push_back({severity, "<command line>", 0, text + " (in a define: -D or the pack's \"defines\")"});
        continue;
      }
      messages.push_back({severity, m[2], std::stoi(m[3]), std::move(text)});
    } else if (std::regex_match(line, m, grammar)) {
      // Its column counts in the preprocessed text, whose spacing is not the file's: the token there.
      messages.push_back({Severity::Error, m[1], std::stoi(m[2]), m[4]});
      if (!parsed.empty()) name_token(messages.back(), parsed, std::stoi(m[3]));
    } else if (std::regex_match(line, m, plain)) {
      std::string text = m[2];
      if (std::regex_search(text, summary)) continue;
      Severity severity = m[1] == "WARNING" ? Severity::Warning : Severity::Error;
      messages.push_back({severity, std::string(fallback_path), 0, text});
    }
  }
  return messages;
}

}  // namespace kiln
