// SPDX-License-Identifier: Apache-2.0
#include "frontend/glslang_shader.hpp"

#include <algorithm>
#include <cctype>

#include "frontend/interface_semantics.hpp"

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

// The pipe inputs and outputs among the tree's symbols (the entry point's linker objects), with their semantics.
class InterfaceSemanticsOf final : public glslang::TIntermTraverser {
 public:
  explicit InterfaceSemanticsOf(InterfaceSemantics& out) : out_(out) {}
  void visitSymbol(glslang::TIntermSymbol* symbol) override {
    const glslang::TQualifier& qualifier = symbol->getQualifier();
    if (qualifier.semanticName == nullptr) return;
    if (qualifier.storage != glslang::EvqVaryingIn && qualifier.storage != glslang::EvqVaryingOut) return;
    std::string semantic(qualifier.semanticName);
    std::transform(semantic.begin(), semantic.end(), semantic.begin(), [](unsigned char c) { return std::toupper(c); });
    out_.emplace(symbol->getName().c_str(), std::move(semantic));
  }

 private:
  InterfaceSemantics& out_;
};

}  // namespace

InterfaceSemantics interface_semantics(const glslang::TIntermediate& intermediate) {
  InterfaceSemantics semantics;
  if (TIntermNode* root = intermediate.getTreeRoot()) {
    InterfaceSemanticsOf traverser(semantics);
    root->traverse(&traverser);
  }
  return semantics;
}

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
