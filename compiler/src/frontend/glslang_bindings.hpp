// glslang's side of the binding model (docs/bindings.md): a resolver for TProgram::mapIO.
#pragma once

#include <glslang/Public/ShaderLang.h>

#include <string>
#include <string_view>

#include "kiln/model.hpp"

namespace kiln {

// Assigns every resource of the linked program's one stage its set and binding; `source` is the
// preprocessed text (read for [[vk::binding]] attributes). False, with the reason in `error`, on failure.
bool map_glslang_bindings(glslang::TProgram& program, EShLanguage stage, const BindingOptions& options,
                          std::string_view source, std::string& error);

}  // namespace kiln
