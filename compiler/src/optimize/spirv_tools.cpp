// SPDX-License-Identifier: Apache-2.0
#include "common/target_environment.hpp"
#include "optimize/spirv_tools.hpp"
#include "optimize/combine_texture_arrays.hpp"

#include <spirv-tools/libspirv.hpp>
#include <spirv-tools/optimizer.hpp>
#include <spirv_cross/spirv.hpp>  // the SPIR-V enums only

#include <map>
#include <set>

namespace kiln {
namespace {

// One step's outcome inside this file; the public functions return it as a SpirvResult (spirv_tools.hpp).
struct Step {
  bool ok = false;
  CompileStep step = CompileStep::None;
  std::vector<std::string> messages;
  std::vector<uint32_t> spirv;
  bool full_legalization = false;
};

SpirvResult finished(Step step) {
  if (step.ok) return SpirvModule{std::move(step.spirv), step.full_legalization};
  return failure(SpirvFailure{step.step, std::move(step.messages)});
}

constexpr spv_target_env kTargetEnv = spirv_tools_environment();

spvtools::MessageConsumer collect_into(std::vector<std::string>& messages) {
  return [&messages](spv_message_level_t level, const char*, const spv_position_t& position, const char* text) {
    if (level > SPV_MSG_WARNING) return;
    std::string message = text ? text : "";
    if (position.index) message = "instruction " + std::to_string(position.index) + ": " + message;
    // spirv-val ends a message with the disassembled instruction and a newline: keep the instruction only.
    while (!message.empty() && (message.back() == '\n' || message.back() == ' ')) message.pop_back();
    messages.push_back(std::move(message));
  };
}

// kiln validates explicitly after legalization and after optimization; the optimizer's own validation of
// its input would repeat that work (and the raw front-end output is not legal SPIR-V yet anyway).
spvtools::OptimizerOptions optimizer_options() {
  spvtools::OptimizerOptions options;
  options.set_run_validator(false);
  return options;
}

bool run_validator(const std::vector<uint32_t>& spirv, std::vector<std::string>& messages) {
  spvtools::SpirvTools tools(kTargetEnv);
  tools.SetMessageConsumer(collect_into(messages));
  spvtools::ValidatorOptions options;
  return tools.Validate(spirv.data(), spirv.size(), options);
}

}  // namespace

static Step validate_step(const std::vector<uint32_t>& spirv) {
  Step result;
  result.step = CompileStep::Validate;
  result.ok = run_validator(spirv, result.messages);
  if (result.ok) result.spirv = spirv;
  return result;
}

namespace {

Step run_recipe(const std::vector<uint32_t>& spirv, CompileStep step, void (*recipe)(spvtools::Optimizer&)) {
  Step result;
  result.step = step;
  spvtools::Optimizer optimizer(kTargetEnv);
  optimizer.SetMessageConsumer(collect_into(result.messages));
  recipe(optimizer);
  result.ok = optimizer.Run(spirv.data(), spirv.size(), &result.spirv, optimizer_options());
  if (!result.ok) result.spirv.clear();
  return result;
}

}  // namespace

static Step legalize_step(const std::vector<uint32_t>& spirv) {
  return run_recipe(spirv, CompileStep::Legalize, [](spvtools::Optimizer& o) { o.RegisterLegalizationPasses(); });
}

namespace {

// The first sixteen passes of SPIRV-Tools' legalization recipe (RegisterLegalizationPasses, 2023.1): wrap
// OpKill, merge returns, inline everything, drop the dead functions, make private variables local, fix the
// storage classes, forward single-block and single-store values, scalar replacement, SSA rewrite, with
// aggressive DCE between. That removes what makes glslang's HLSL output illegal in the common case: opaque
// objects (textures, samplers, buffers) passed through function parameters, locals and structs. The rest of
// the full recipe (CCP, loop unrolling, dead-branch elimination, simplification, copy propagation of arrays,
// vector DCE, dead-insert elimination, load-size reduction) legalizes harder cases (a texture chosen by a
// constant condition, an array of textures indexed in an unrolled loop) and is otherwise optimization that
// `-O` runs again right after. Measured on the bundled library: the same -O output, instruction for
// instruction, for every module (only the ID numbering differs), 11% less SPIRV-Tools time.
void register_core_legalization(spvtools::Optimizer& o) {
  o.RegisterPass(spvtools::CreateWrapOpKillPass())
      .RegisterPass(spvtools::CreateDeadBranchElimPass())
      .RegisterPass(spvtools::CreateMergeReturnPass())
      .RegisterPass(spvtools::CreateInlineExhaustivePass())
      .RegisterPass(spvtools::CreateEliminateDeadFunctionsPass())
      .RegisterPass(spvtools::CreatePrivateToLocalPass())
      .RegisterPass(spvtools::CreateFixStorageClassPass())
      .RegisterPass(spvtools::CreateLocalSingleBlockLoadStoreElimPass())
      .RegisterPass(spvtools::CreateLocalSingleStoreElimPass())
      .RegisterPass(spvtools::CreateAggressiveDCEPass())
      .RegisterPass(spvtools::CreateScalarReplacementPass(0))
      .RegisterPass(spvtools::CreateLocalSingleBlockLoadStoreElimPass())
      .RegisterPass(spvtools::CreateLocalSingleStoreElimPass())
      .RegisterPass(spvtools::CreateAggressiveDCEPass())
      .RegisterPass(spvtools::CreateSSARewritePass())
      .RegisterPass(spvtools::CreateAggressiveDCEPass());
}

// SPIRV-Tools' -O (RegisterPerformancePasses, 2023.1) pass for pass, each with whether kiln's recipe keeps it.
// Kiln's recipe leaves out only passes that provably have nothing to do on the core legalization recipe's
// output (its last passes are -O's first ones) when `fits_kiln_recipe` holds, which kiln checks on every module:
//   - no OpFunctionCall, and every function is an entry point: wrap-opkill (acts only on functions called
//     from a continue construct), inline-entry-points-exhaustive (acts only on calls) and
//     eliminate-dead-functions (removes functions no entry point reaches) have nothing to act on;
//   - no Private variable: private-to-local has nothing to move;
//   - at most one return per function, in its last block (checked), and outside any construct: the core
//     recipe's merge-return made it so before inlining, inlining adds no construct around the caller's return
//     and no later pass adds one. Merge-return leaves such a function alone;
//   - local single-block and single-store elimination act only on loads of function variables whose every
//     use is a load or a store (MemPass::HasOnlySupportedRefs); the core recipe's last SSA rewrite replaced
//     every load of those variables and its last ADCE removed them. In between only dead-branch elimination
//     and ADCE run, which delete code and create no load or store;
//   - the ADCE after those two repeats the ADCE before them with nothing in between that changes the module.
// Every other pass stays, even where it changed no module of the bundled library (measured per pass by
// kiln-optimizer-passes, bench/REPORT.md): nothing proves it idle on every input. optimizer_recipe_test.cpp
// requires -O's modules, IDs compacted, on the bundled library's default pack and on tests/corpus.
struct RecipePass {
  spvtools::Optimizer::PassToken (*make)();
  bool kiln;  // in kiln's recipe
};
// clang-format off
const RecipePass kStockRecipe[] = {
    {[] { return spvtools::CreateWrapOpKillPass(); }, false},                // no calls
    {[] { return spvtools::CreateDeadBranchElimPass(); }, true},
    {[] { return spvtools::CreateMergeReturnPass(); }, false},               // one return, last, since the core recipe
    {[] { return spvtools::CreateInlineExhaustivePass(); }, false},          // no calls
    {[] { return spvtools::CreateEliminateDeadFunctionsPass(); }, false},    // every function an entry point
    {[] { return spvtools::CreateAggressiveDCEPass(); }, true},
    {[] { return spvtools::CreatePrivateToLocalPass(); }, false},            // no Private variable
    {[] { return spvtools::CreateLocalSingleBlockLoadStoreElimPass(); }, false},  // after the core recipe's SSA rewrite
    {[] { return spvtools::CreateLocalSingleStoreElimPass(); }, false},           // after the core recipe's SSA rewrite
    {[] { return spvtools::CreateAggressiveDCEPass(); }, false},             // repeats the ADCE above, nothing between
    {[] { return spvtools::CreateScalarReplacementPass(); }, true},
    {[] { return spvtools::CreateLocalAccessChainConvertPass(); }, true},
    {[] { return spvtools::CreateLocalSingleBlockLoadStoreElimPass(); }, true},
    {[] { return spvtools::CreateLocalSingleStoreElimPass(); }, true},
    {[] { return spvtools::CreateAggressiveDCEPass(); }, true},
    {[] { return spvtools::CreateLocalMultiStoreElimPass(); }, true},
    {[] { return spvtools::CreateAggressiveDCEPass(); }, true},
    {[] { return spvtools::CreateCCPPass(); }, true},
    {[] { return spvtools::CreateAggressiveDCEPass(); }, true},
    {[] { return spvtools::CreateLoopUnrollPass(true); }, true},
    {[] { return spvtools::CreateDeadBranchElimPass(); }, true},
    {[] { return spvtools::CreateRedundancyEliminationPass(); }, true},
    {[] { return spvtools::CreateCombineAccessChainsPass(); }, true},
    {[] { return spvtools::CreateSimplificationPass(); }, true},
    {[] { return spvtools::CreateScalarReplacementPass(); }, true},
    {[] { return spvtools::CreateLocalAccessChainConvertPass(); }, true},
    {[] { return spvtools::CreateLocalSingleBlockLoadStoreElimPass(); }, true},
    {[] { return spvtools::CreateLocalSingleStoreElimPass(); }, true},
    {[] { return spvtools::CreateAggressiveDCEPass(); }, true},
    {[] { return spvtools::CreateSSARewritePass(); }, true},
    {[] { return spvtools::CreateAggressiveDCEPass(); }, true},
    {[] { return spvtools::CreateVectorDCEPass(); }, true},
    {[] { return spvtools::CreateDeadInsertElimPass(); }, true},
    {[] { return spvtools::CreateDeadBranchElimPass(); }, true},
    {[] { return spvtools::CreateSimplificationPass(); }, true},
    {[] { return spvtools::CreateIfConversionPass(); }, true},
    {[] { return spvtools::CreateCopyPropagateArraysPass(); }, true},
    {[] { return spvtools::CreateReduceLoadSizePass(); }, true},
    {[] { return spvtools::CreateAggressiveDCEPass(); }, true},
    {[] { return spvtools::CreateBlockMergePass(); }, true},
    {[] { return spvtools::CreateRedundancyEliminationPass(); }, true},
    {[] { return spvtools::CreateDeadBranchElimPass(); }, true},
    {[] { return spvtools::CreateBlockMergePass(); }, true},
    {[] { return spvtools::CreateSimplificationPass(); }, true},
};
// clang-format on

void register_kiln_recipe(spvtools::Optimizer& o) {
  for (const RecipePass& pass : kStockRecipe)
    if (pass.kiln) o.RegisterPass(pass.make());
}

void register_recipe(spvtools::Optimizer& o, OptimizerRecipe recipe) {
  if (recipe == OptimizerRecipe::Stock) {
    o.RegisterPerformancePasses();
    return;
  }
  register_kiln_recipe(o);
}

}  // namespace

static Step legalize_core_step(const std::vector<uint32_t>& spirv) {
  return run_recipe(spirv, CompileStep::Legalize, register_core_legalization);
}

bool fits_kiln_recipe(const std::vector<uint32_t>& spirv) {
  std::set<uint32_t> entry_points, functions;
  int returns = 0;             // in the current function
  bool label_after_return = false;  // the return is not in the function's last block
  for (size_t at = 5; at < spirv.size();) {
    const uint32_t count = spirv[at] >> 16, opcode = spirv[at] & 0xffff;
    if (count == 0 || at + count > spirv.size()) return false;
    const uint32_t* w = &spirv[at];
    switch (opcode) {
      case spv::OpFunctionCall: return false;
      case spv::OpVariable:
        if (count >= 4 && w[3] == spv::StorageClassPrivate) return false;
        break;
      case spv::OpEntryPoint:
        if (count >= 3) entry_points.insert(w[2]);
        break;
      case spv::OpFunction:
        if (count >= 3) functions.insert(w[2]);
        returns = 0;
        label_after_return = false;
        break;
      case spv::OpReturn:
      case spv::OpReturnValue: ++returns; break;
      case spv::OpLabel: label_after_return |= returns > 0; break;
      case spv::OpFunctionEnd:
        if (returns > 1 || label_after_return) return false;
        break;
      default: break;
    }
    at += count;
  }
  return functions == entry_points;
}

static Step optimize_step(const std::vector<uint32_t>& spirv, OptimizerRecipe recipe) {
  if (recipe == OptimizerRecipe::Kiln && !fits_kiln_recipe(spirv)) recipe = OptimizerRecipe::Stock;
  Step result;
  result.step = CompileStep::Optimize;
  spvtools::Optimizer optimizer(kTargetEnv);
  optimizer.SetMessageConsumer(collect_into(result.messages));
  register_recipe(optimizer, recipe);
  result.ok = optimizer.Run(spirv.data(), spirv.size(), &result.spirv, optimizer_options());
  if (!result.ok) result.spirv.clear();
  return result;
}

namespace {

std::vector<std::string> names_of(const spvtools::Optimizer& optimizer) {
  std::vector<std::string> names;
  for (const char* name : optimizer.GetPassNames()) names.emplace_back(name);
  return names;
}

}  // namespace

std::vector<std::string> legalization_pass_names() {
  spvtools::Optimizer optimizer(kTargetEnv);
  register_core_legalization(optimizer);
  return names_of(optimizer);
}

std::vector<std::string> optimizer_pass_names(OptimizerRecipe recipe) {
  spvtools::Optimizer optimizer(kTargetEnv);
  register_recipe(optimizer, recipe);
  return names_of(optimizer);
}

std::vector<uint32_t> compact_ids(const std::vector<uint32_t>& spirv) {
  spvtools::Optimizer optimizer(kTargetEnv);
  optimizer.RegisterPass(spvtools::CreateCompactIdsPass());
  std::vector<uint32_t> out;
  if (!optimizer.Run(spirv.data(), spirv.size(), &out, optimizer_options())) return spirv;
  return out;
}

namespace {

// Legalized and validated. Before -O, the core recipe first; when its result does not validate (or a pass
// fails), the full recipe from the front end's module, as `spirv-opt --legalize-hlsl` would: every module
// the full recipe legalizes is accepted. Without -O the full recipe only, so that an unoptimized build is
// what `--legalize-hlsl` gives.
Step legalize_and_validate(const std::vector<uint32_t>& spirv, bool optimize) {
  if (optimize) {
    Step core = legalize_core_step(spirv);
    if (core.ok) {
      std::vector<std::string> rejected;
      if (run_validator(core.spirv, rejected)) {
        core.step = CompileStep::Validate;
        return core;
      }
    }
  }
  Step full = legalize_step(spirv);
  full.full_legalization = true;
  if (!full.ok) return full;
  full.step = CompileStep::Validate;
  full.ok = run_validator(full.spirv, full.messages);
  return full;
}

}  // namespace

static Step chain_step(std::vector<uint32_t> spirv, bool optimize, OptimizerRecipe recipe,
                       const std::function<void()>& legalized) {
  Step result = legalize_and_validate(spirv, optimize);
  if (legalized) legalized();
  if (!result.ok || !optimize) return result;
  // Kiln's recipe leaves out work the core legalization recipe did; after the full one, -O as a whole.
  Step optimized = optimize_step(result.spirv, result.full_legalization ? OptimizerRecipe::Stock : recipe);
  optimized.full_legalization = result.full_legalization;
  optimized.messages.insert(optimized.messages.begin(), result.messages.begin(), result.messages.end());
  if (!optimized.ok) return optimized;
  optimized.step = CompileStep::ValidateOptimized;
  optimized.ok = run_validator(optimized.spirv, optimized.messages);
  return optimized;
}

namespace {

// (set, binding) of every slot that a texture variable and a sampler variable both decorate.
std::set<std::pair<uint32_t, uint32_t>> shared_texture_sampler_slots(const std::vector<uint32_t>& spirv) {
  enum Kind { Other, Image, Sampler };
  std::map<uint32_t, Kind> type_kind;           // type id -> what it is (through pointers and arrays)
  std::map<uint32_t, uint32_t> set_of, binding_of;
  std::map<uint32_t, Kind> variables;
  for (size_t at = 5; at < spirv.size();) {
    const uint32_t count = spirv[at] >> 16, opcode = spirv[at] & 0xffff;
    if (count == 0 || at + count > spirv.size()) break;
    const uint32_t* w = &spirv[at];
    switch (opcode) {
      case spv::OpDecorate:
        if (count >= 4 && w[2] == spv::DecorationDescriptorSet) set_of[w[1]] = w[3];
        if (count >= 4 && w[2] == spv::DecorationBinding) binding_of[w[1]] = w[3];
        break;
      case spv::OpTypeImage: type_kind[w[1]] = Image; break;
      case spv::OpTypeSampler: type_kind[w[1]] = Sampler; break;
      case spv::OpTypeArray:
      case spv::OpTypeRuntimeArray: type_kind[w[1]] = type_kind[w[2]]; break;
      case spv::OpTypePointer: type_kind[w[1]] = type_kind[w[3]]; break;
      case spv::OpVariable:
        if (type_kind[w[1]] != Other) variables[w[2]] = type_kind[w[1]];
        break;
      default: break;
    }
    at += count;
  }
  std::map<std::pair<uint32_t, uint32_t>, int> seen;  // bit 1: a texture, bit 2: a sampler
  for (const auto& [id, kind] : variables)
    if (binding_of.count(id)) seen[{set_of[id], binding_of[id]}] |= kind == Image ? 1 : 2;
  std::set<std::pair<uint32_t, uint32_t>> slots;
  for (const auto& [slot, kinds] : seen)
    if (kinds == 3) slots.insert(slot);
  return slots;
}

}  // namespace

static Step combine_step(const std::vector<uint32_t>& input) {
  Step result;
  result.step = CompileStep::CombineImageSamplers;
  // A texture array and its sampler first, by kiln's own pass (combine_texture_arrays.hpp): SPIRV-Tools' pass
  // takes single textures only.
  Result<CombinedTextureArrays> arrays = combine_texture_arrays(input);
  if (!arrays) {
    result.messages.push_back(arrays.error().message);
    return result;
  }
  const std::vector<uint32_t>& spirv = arrays->spirv;
  const auto slots = shared_texture_sampler_slots(spirv);
  if (slots.empty() && arrays->slots.empty()) {
    result.ok = true;
    result.spirv = spirv;
    return result;
  }
  std::vector<std::string> passes;
  if (!slots.empty()) {
    std::string flag = "--convert-to-sampled-image=";
    for (const auto& [set, binding] : slots) flag += std::to_string(set) + ":" + std::to_string(binding) + " ";
    flag.pop_back();
    passes.push_back(flag);
  }
  // Both leave the sampler variable behind, loaded but no longer used: removed, so that the reflection and the GL
  // and MSL outputs show one combined binding.
  passes.push_back("--eliminate-dead-code-aggressive");
  passes.push_back("--eliminate-dead-variables");
  spvtools::Optimizer optimizer(kTargetEnv);
  optimizer.SetMessageConsumer(collect_into(result.messages));
  for (const std::string& pass : passes)
    if (!optimizer.RegisterPassFromFlag(pass)) {
      result.messages.push_back("SPIRV-Tools does not know " + pass);
      return result;
    }
  const bool converted = optimizer.Run(spirv.data(), spirv.size(), &result.spirv, optimizer_options());
  if (!converted && result.messages.empty()) {
    // The pass says nothing when it refuses: a sampler that shares a binding with one texture must sample
    // only that texture (and the texture be sampled only through it) to become one combined image sampler.
    std::string where;
    for (const auto& [set, binding] : slots)
      where += (where.empty() ? "" : ", ") + std::string("set ") + std::to_string(set) + " binding " + std::to_string(binding);
    result.messages.push_back("the texture and the sampler at " + where +
                              " cannot become one combined image sampler: the sampler also samples another texture, or "
                              "the texture is sampled with another sampler; give the sampler its own binding (an s shift)");
  }
  result.ok = converted && run_validator(result.spirv, result.messages);
  if (!result.ok) result.spirv.clear();
  return result;
}

std::string disassemble_spirv(const std::vector<uint32_t>& spirv) {
  spvtools::SpirvTools tools(kTargetEnv);
  std::string text;
  tools.Disassemble(spirv, &text, SPV_BINARY_TO_TEXT_OPTION_INDENT | SPV_BINARY_TO_TEXT_OPTION_FRIENDLY_NAMES);
  return text;
}

std::string spirv_tools_version() { return spvSoftwareVersionString(); }

SpirvResult legalize_validate_optimize(std::vector<uint32_t> spirv, bool optimize, OptimizerRecipe recipe,
                                       const std::function<void()>& legalized) {
  return finished(chain_step(std::move(spirv), optimize, recipe, legalized));
}
SpirvResult legalize_spirv(const std::vector<uint32_t>& spirv) { return finished(legalize_step(spirv)); }
SpirvResult legalize_spirv_core(const std::vector<uint32_t>& spirv) { return finished(legalize_core_step(spirv)); }
SpirvResult optimize_spirv(const std::vector<uint32_t>& spirv, OptimizerRecipe recipe) {
  return finished(optimize_step(spirv, recipe));
}
SpirvResult combine_image_samplers(const std::vector<uint32_t>& spirv) { return finished(combine_step(spirv)); }
Result<void, SpirvFailure> validate_spirv(const std::vector<uint32_t>& spirv) {
  Step step = validate_step(spirv);
  if (step.ok) return {};
  return failure(SpirvFailure{step.step, std::move(step.messages)});
}

}  // namespace kiln
