#include "frontend/glslang_shader.hpp"

#include <glslang/Include/intermediate.h>
#include <glslang/MachineIndependent/localintermediate.h>

namespace kiln {
namespace {

class ShaderWithSemantics final : public glslang::TShader {
 public:
  explicit ShaderWithSemantics(EShLanguage language) : glslang::TShader(language) { environment.target.hlslFunctionality1 = true; }
};

class LexicalScopesToSequences final : public glslang::TIntermTraverser {
 public:
  bool visitAggregate(glslang::TVisit, glslang::TIntermAggregate* node) override {
    if (node->getOp() == glslang::EOpScope) node->setOperator(glslang::EOpSequence);
    return true;
  }
};

}  // namespace

void without_lexical_scopes(glslang::TIntermediate& intermediate) {
  if (TIntermNode* root = intermediate.getTreeRoot()) {  // glslang declares TIntermNode outside its namespace
    LexicalScopesToSequences traverser;
    root->traverse(&traverser);
  }
}

std::unique_ptr<glslang::TShader> make_glslang_shader(EShLanguage stage, bool semantics) {
  if (semantics) return std::make_unique<ShaderWithSemantics>(stage);
  return std::make_unique<glslang::TShader>(stage);
}

}  // namespace kiln
