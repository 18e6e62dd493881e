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

}  // namespace kiln
