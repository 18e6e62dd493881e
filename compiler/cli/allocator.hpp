// SPDX-License-Identifier: Apache-2.0
// Which malloc serves this executable: mimalloc when kiln is configured with KILN_MIMALLOC (the default) and
// its library really precedes libc in the symbol lookup, glibc's otherwise. Asked of the live allocator,
// not of the build flag, so a link-order mistake shows up in `kiln --version`.
#pragma once

#include <string>

namespace kiln {

std::string allocator_description();

}  // namespace kiln
