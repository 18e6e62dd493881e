// SPDX-License-Identifier: Apache-2.0
// A glslang shader that can ask for hlsl_functionality1's semantic decorations. Debian's headers declare
// TShader::setEnvTargetHlslFunctionality1 only where ENABLE_HLSL is defined, which would have to hold for every file
// of a unity build; and a class derived from TShader must be compiled without RTTI, as Debian's glslang is
// (glslang_shader.cpp, -fno-rtti).
#pragma once

#include <glslang/Public/ShaderLang.h>

#include <memory>

namespace kiln {

// `semantics`: the SPIR-V carries each interface variable's HLSL semantic (UserSemantic decorations).
std::unique_ptr<glslang::TShader> make_glslang_shader(EShLanguage stage, bool semantics);

// glslang 12 reads a debug scope it never pushed when it meets a lexical block (EOpScope) with debug information on:
// spv::Builder::makeDebugLexicalBlock takes the top of an empty stack (valgrind: an invalid read; under mimalloc, a
// crash). Before GlslangToSpv, each block becomes a plain sequence: the module keeps its lines, functions and
// variables, with each variable in its function's scope instead of its block's.
void without_lexical_scopes(glslang::TIntermediate& intermediate);

}  // namespace kiln
