// SPDX-License-Identifier: Apache-2.0
// Making glslang's preprocessed text a faithful token stream.
//
// kiln preprocesses each stage source once, keys the cache and the deduplication on the preprocessed
// text, and compiles that text. glslang's preprocessor output (TShader::preprocess) does not round-trip
// every token: it prints a token's spelling as its scanner stored it, so
//   - a character literal 'A' is printed as A (its value's character), '\n' as a raw newline;
//   - 1.#INF is printed as 1.INF;
//   - a string literal is printed with its escapes already applied ("a\"b" becomes "a"b").
// Compiled again, `int c = 'A';` silently means `int c = A;`. So before preprocessing, kiln rewrites
// those tokens into spellings that survive (protect_literals), and after it restores the strings
// (restore_literals). Everything is stateless: the same file text gives the same protected text.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace kiln {

// Strings whose escapes would not survive become `"__kiln_lit_<hex of the original spelling>"`;
// identifiers beginning with `__kiln_lit_` are reserved for that. Chosen so that a compiled result
// is the one glslang gives for the original text:
//   - a character literal glslang accepts becomes its value as a decimal integer (what glslang's
//     scanner makes of it), padded with spaces to the same width, so columns and #if values hold;
//   - 1.#INF becomes 1e999 (glslang scans both to the float +infinity);
//   - strings on #include, #line, #error, #pragma and other non-#define directive lines are left as
//     they are: glslang reads those itself.
// Comments and line structure are kept; nothing else changes. Nothing if the text needs no change.
std::optional<std::string> protect_literals(std::string_view text);

// Puts the original spelling back for every protected string in preprocessed text.
// Nothing if the text holds none.
std::optional<std::string> restore_literals(std::string_view preprocessed);

}  // namespace kiln
