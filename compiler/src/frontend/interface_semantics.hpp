// SPDX-License-Identifier: Apache-2.0
// The HLSL semantics of a stage's inputs and outputs (POSITION, TEXCOORD0, SV_Target...), for the reflection a game
// binds vertex buffers by. glslang 12 knows them (each interface variable's qualifier) but writes them into the SPIR-V
// only with hlsl_functionality1, which would add an extension and decorations to every module. So the front end
// carries them to the back end on its own module, as that extension's UserSemantic decorations
// (attach_interface_semantics), and the back end takes them off before anything else reads the module
// (detach_interface_semantics): the modules kiln outputs are the bytes they were without them.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "kiln/result.hpp"

namespace glslang {
class TIntermediate;
}

namespace kiln {

// Interface variable name (as the module's OpName has it: "i.uv", "@entryPointOutput") -> its semantic, upper case.
using InterfaceSemantics = std::map<std::string, std::string>;

// The semantics of the stage's input and output variables, from glslang's tree (frontend/glslang_shader.cpp: glslang's
// classes are compiled without RTTI).
InterfaceSemantics interface_semantics(const glslang::TIntermediate& intermediate);

// On the front end's module: a UserSemantic decoration on each Input and Output variable named in `semantics`, and
// the extension. Fails when the module does not parse (nothing to add is success).
Result<void> attach_interface_semantics(std::vector<uint32_t>& spirv, const InterfaceSemantics& semantics);
// In the back end, first: the semantics attach_interface_semantics put on, by variable name, taken off with the
// extension (the module is then the front end's own). A module without them is left as it is.
InterfaceSemantics detach_interface_semantics(std::vector<uint32_t>& spirv);

}  // namespace kiln
