#include "frontend/glslang_shader.hpp"

namespace kiln {
namespace {

class ShaderWithSemantics final : public glslang::TShader {
 public:
  explicit ShaderWithSemantics(EShLanguage language) : glslang::TShader(language) { environment.target.hlslFunctionality1 = true; }
};

}  // namespace

std::unique_ptr<glslang::TShader> make_glslang_shader(EShLanguage stage, bool semantics) {
  if (semantics) return std::make_unique<ShaderWithSemantics>(stage);
  return std::make_unique<glslang::TShader>(stage);
}

}  // namespace kiln
