// SPDX-License-Identifier: Apache-2.0
// The HLSL front end, behind an interface: glslang today (its HLSL path was deprecated upstream in
// 2026); DXC or Slang can be added as another implementation without touching the other stages.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "common/compile_result.hpp"
#include "kiln/build.hpp"
#include "kiln/diagnostics.hpp"
#include "kiln/model.hpp"
#include "kiln/result.hpp"

namespace kiln {

// Serves #include requests during preprocessing from kiln's confined source set.
class IncludeSource {
 public:
  virtual ~IncludeSource() = default;
  struct Found {
    std::string name;  // shown in #line directives and diagnostics
    std::string_view text;
    bool once = false;  // file has #pragma once / include guard
  };
  // `from` is the name (as returned here, or the entry's name) of the including file.
  virtual Result<Found> resolve(std::string_view requested, std::string_view from) const = 0;
};

struct PreprocessRequest {
  Stage stage = Stage::Fragment;
  std::string entry_name;  // shown in #line directives
  std::string_view entry_text;
  std::vector<std::string> defines;  // "NAME" becomes `#define NAME 1`, "NAME=VALUE" `#define NAME VALUE`
  const IncludeSource* includes = nullptr;
};

struct PreprocessResult {
  bool ok = false;
  std::string text;
  std::vector<FrontendMessage> messages;
};

// A file as written: -g modules carry it in OpSource (what DXC and glslangValidator -g keep), not the text kiln
// preprocessed.
struct SourceText {
  std::string_view name;  // as the preprocessed text's #line directives name it
  std::string_view text;
};

struct CompileRequest {
  Stage stage = Stage::Fragment;
  std::string entry_point;
  std::string source_name;
  std::string_view source;  // preprocessed
  BindingOptions bindings;  // how registers become bindings (docs/bindings.md)
  bool debug_info = false;  // OpSource with the text, OpLine and names (BuildOptions::debug_info)
  std::vector<SourceText> debug_sources;  // debug_info: the files the source came from, its entry first; none: its text
};

struct CompileResult {
  bool ok = false;
  bool missing_entry_point = false;
  std::vector<uint32_t> spirv;
  std::vector<FrontendMessage> messages;
};

class Frontend {
 public:
  virtual ~Frontend() = default;
  virtual std::string name() const = 0;
  virtual std::string version() const = 0;
  virtual PreprocessResult preprocess(const PreprocessRequest& request) = 0;
  virtual CompileResult compile(const CompileRequest& request) = 0;
};

// The front ends by name: the build, its compiler workers and the cache key name the front end, so that
// adding one touches only frontend/ (its implementation and a line in registry.cpp).
inline constexpr std::string_view kDefaultFrontend = "glslang";
std::unique_ptr<Frontend> make_frontend(std::string_view name);  // nullptr: no front end of that name

std::unique_ptr<Frontend> make_glslang_frontend();

// Parses glslang-style info logs ("ERROR: path:line: message") into messages. `parsed`: the text glslang parsed
// (its #line directives name the files' lines); a column glslang gives in it becomes the token there
// (FrontendMessage::token), since the file's own spacing is not the parsed text's.
std::vector<FrontendMessage> parse_frontend_log(std::string_view log, std::string_view fallback_path,
                                                std::string_view parsed = {});

}  // namespace kiln
