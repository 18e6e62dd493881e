// SPDX-License-Identifier: Apache-2.0
#include "frontend/glslang_bindings.hpp"

#include <glslang/MachineIndependent/iomapper.h>
#include <glslang/MachineIndependent/localintermediate.h>

#include <map>
#include <sstream>

#include "frontend/bindings.hpp"

namespace kiln {
namespace {

// glslang's own HLSL resolver (TDefaultHlslIoResolver, private to glslang) shifts every explicit binding,
// [[vk::binding]] included, and knows nothing of $Global: DXC's rules need a resolver of kiln's own. The
// register class of a resource is the one D3D gives it, as glslang's HLSL resolver decides it.
class KilnResolver final : public glslang::TDefaultIoResolverBase {
 public:
  KilnResolver(const glslang::TIntermediate& intermediate, const BindingOptions& options,
               std::map<std::string, std::pair<uint32_t, uint32_t>> pinned)
      : TDefaultIoResolverBase(intermediate), options_(options), pinned_(std::move(pinned)) {}

  bool validateBinding(EShLanguage, glslang::TVarEntryInfo&) override { return true; }

  glslang::TResourceType getResourceType(const glslang::TType& type) override {
    if (isUavType(type)) return glslang::EResUav;
    if (isSrvType(type)) return glslang::EResTexture;
    if (isSamplerType(type)) return glslang::EResSampler;
    if (isUboType(type)) return glslang::EResUbo;
    return glslang::EResCount;
  }

  int resolveBinding(EShLanguage, glslang::TVarEntryInfo& ent) override {
    const glslang::TType& type = ent.symbol->getType();
    const glslang::TResourceType resource = getResourceType(type);
    // Dead resources are bound too (they are not emitted): every stage and variant of a source then numbers
    // its automatic bindings alike, whichever resources its entry point uses.
    if (resource == glslang::EResCount) return ent.newBinding = -1;
    if (auto pin = pinned(type, ent)) return ent.newBinding = reserveSlot(static_cast<int>(pin->second), static_cast<int>(pin->first));
    const int set = getLayoutSet(type);
    const int base = static_cast<int>(options_.shift(register_class(resource), static_cast<uint32_t>(set)));
    if (type.getQualifier().hasBinding()) return ent.newBinding = reserveSlot(set, base + type.getQualifier().layoutBinding);
    if (options_.auto_binds()) return ent.newBinding = getFreeSlot(set, base);
    return ent.newBinding = -1;
  }

  int resolveSet(EShLanguage stage, glslang::TVarEntryInfo& ent) override {
    if (auto pin = pinned(ent.symbol->getType(), ent)) return ent.newSet = static_cast<int>(pin->second);
    return TDefaultIoResolverBase::resolveSet(stage, ent);
  }

 private:
  RegisterClass register_class(glslang::TResourceType resource) const {
    switch (resource) {
      case glslang::EResUbo: return RegisterClass::B;
      // Combined mode: a sampler lands where the texture of its register number does.
      case glslang::EResSampler: return options_.combines() ? RegisterClass::T : RegisterClass::S;
      case glslang::EResUav: return RegisterClass::U;
      default: return RegisterClass::T;
    }
  }
  // (binding, set) stated by [[vk::binding]] or, for $Global, by the options: taken as they are.
  std::optional<std::pair<uint32_t, uint32_t>> pinned(const glslang::TType& type, const glslang::TVarEntryInfo& ent) const {
    const bool block = type.getBasicType() == glslang::EbtBlock;
    if (block && options_.global_uniform && type.getTypeName() == "$Global") return options_.global_uniform;
    // A cbuffer is an anonymous block instance ("anon@0"): its name is the block's. ConstantBuffer<T> name
    // and StructuredBuffer<T> name are named by their variable.
    const std::string variable(ent.symbol->getName().c_str());
    const std::string name = block && (variable.empty() || variable.starts_with("anon@")) ? type.getTypeName().c_str() : variable;
    if (auto it = pinned_.find(name); it != pinned_.end()) return it->second;
    return std::nullopt;
  }
  // The configured $Global slot is taken before any resource is bound automatically.
  void beginResolve(EShLanguage) override {
    if (options_.global_uniform)
      reserveSlot(static_cast<int>(options_.global_uniform->second), static_cast<int>(options_.global_uniform->first));
  }

  const BindingOptions& options_;
  std::map<std::string, std::pair<uint32_t, uint32_t>> pinned_;
};

}  // namespace

Result<void> map_glslang_bindings(glslang::TProgram& program, EShLanguage stage, const BindingOptions& options,
                                  std::string_view source) {
  const glslang::TIntermediate* intermediate = program.getIntermediate(stage);
  if (!intermediate) return failure("no intermediate for the stage");
  KilnResolver resolver(*intermediate, options, find_vk_bindings(source));
  if (!program.mapIO(&resolver)) {
    std::string log = program.getInfoLog();
    return failure(log.empty() ? "assigning bindings failed" : log);
  }
  return {};
}

}  // namespace kiln
