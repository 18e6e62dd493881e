// SPDX-License-Identifier: Apache-2.0
// Limits of a front end's module that glslang does not check, checked where kiln can still name the source.
// A compute shader's thread group: numthreads of
// 0 (which glslang accepts and SPIR-V cannot express) or beyond what D3D guarantees and DXC enforces (x and y at
// most 1024, z at most 64, x*y*z at most 1024; Vulkan, GL and Metal guarantee no more), and groupshared memory
// beyond D3D's 32 KiB (Vulkan guarantees 16 KiB). glslang accepted all of these silently or failed in the back end
// with an internal error.
// Buffer blocks (cbuffer, tbuffer, structured and byte-address buffers, push constants): under 4 GiB, as SPIR-V's
// 32-bit offsets need. A 4 GiB block of two members wrapped its offsets (spirv-val's error), a 4 GiB tbuffer lost
// its name in the back end, a 4 GiB structured-buffer element made SPIRV-Cross throw (an internal error).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/compile_result.hpp"

namespace kiln {

// A message at byte `offset` of preprocessed `text`: the file and line its #line directives give, the column in it.
FrontendMessage located_in_source(std::string_view text, size_t offset, const std::string& source_name, std::string message);

// spirv-val's "conflicting input (output) location assignment at location N" (`message`, its words or
// conflicting_location's), which names no line: located at the second `[[vk::location(N)]]` of the preprocessed `source` (the first when the text
// states N once: it collides with a location glslang assigned), with what to do. Nothing for other messages, or
// when the text states no such location.
std::optional<FrontendMessage> locate_location_conflict(const std::string& message, std::string_view source,
                                                        const std::string& source_name);

// Before the front end: the literal numthreads(x, y, z) of `entry` in the preprocessed `source` (named
// `source_name`, #line directives followed). Empty when they are within the limits or not literal integers.
std::vector<FrontendMessage> check_numthreads_source(std::string_view source, const std::string& source_name,
                                                     const std::string& entry);

// Before the front end, any stage: each file-scope array of structured or byte-address buffers
// (`StructuredBuffer<T> lights[4]`, `RWByteAddressBuffer buffers[]`), which DXC makes a descriptor array of storage
// buffers and glslang 12 cannot: it crashes generating SPIR-V for an access to a structured one (a worker crash,
// K1501) and fails to parse a byte-address one with unrelated errors. One message per declaration, at its name.
std::vector<FrontendMessage> check_buffer_arrays_source(std::string_view source, const std::string& source_name);

// After the front end: the module's thread-group size (whatever expression gave it) and its groupshared bytes.
// Messages are located at the first numthreads or groupshared of `source` when it has one.
std::vector<FrontendMessage> check_compute_module(const std::vector<uint32_t>& spirv, std::string_view source,
                                                  const std::string& source_name);

// After the front end, any stage: each buffer block of 4 GiB or more, as "buffer block 'NAME' is N bytes; ..." (the
// driver reports it as K1409 at the declaration of NAME). A runtime array counts one element.
std::vector<FrontendMessage> check_buffer_blocks(const std::vector<uint32_t>& spirv);

}  // namespace kiln
