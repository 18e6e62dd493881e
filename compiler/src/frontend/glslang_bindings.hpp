// SPDX-License-Identifier: Apache-2.0
// glslang's side of the binding model (docs/bindings.md): a resolver for TProgram::mapIO.
#pragma once

#include <glslang/Public/ShaderLang.h>

#include <string>
#include <string_view>

#include "kiln/model.hpp"
#include "kiln/result.hpp"

namespace kiln {

// Assigns every resource of the linked program's one stage its set and binding; `source` is the
// preprocessed text (read for [[vk::binding]] attributes). The error is glslang's log.
Result<void> map_glslang_bindings(glslang::TProgram& program, EShLanguage stage, const BindingOptions& options,
                                  std::string_view source);

}  // namespace kiln
