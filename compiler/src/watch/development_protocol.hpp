// SPDX-License-Identifier: Apache-2.0
// The development endpoint's request bodies (docs/development-loop.md, "Protocol, version 1"), parsed apart from the
// HTTP server so that the fuzzer (tests/fuzz/endpoint_fuzzer.cpp) runs exactly what watch runs on a body. Every
// body is untrusted: its size, its JSON nesting, its fields and every name in it are checked before it is kept.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "kiln/development_endpoint.hpp"
#include "kiln/result.hpp"

namespace kiln::development {

// A variant a reader asked for (POST /v1/variant), or one it selected (in a SelectedReport).
struct VariantRequest {
  std::string pass;
  std::vector<std::string> keywords;  // sorted, without repeats
};

// What a reader in development mode selected since its last report (POST /v1/selected).
struct SelectedReport {
  std::string client;                     // the reader's own id, 1 to kMaxClientBytes of [A-Za-z0-9._-]
  std::vector<VariantRequest> selected;   // at most kMaxReportedVariants, in the order sent
};

// An HTTP answer: its status and its JSON body.
struct Answer {
  unsigned status = 200;
  std::string body;
};

// {"version": 1, "error": message} with `status`, and `diagnostics` (cut to fit kMaxAnswerBytes) when there are any.
Answer error_answer(unsigned status, const std::string& message, const std::string& diagnostics = {});

// A name the protocol carries (a pass or a keyword): 1 to kMaxNameBytes printable ASCII characters without spaces,
// quotes or backslashes.
bool is_protocol_name(std::string_view text);

// A /v1/variant body: a JSON object with exactly "pass" (a name) and "keywords" (an array of at most kMaxKeywords
// names), at most kMaxRequestBytes, nested at most 3 deep. The error is the 400 to answer.
Result<VariantRequest, Answer> parse_variant_request(std::string_view body);

// A /v1/selected body: a JSON object with exactly "client" (an id) and "selected" (an array of at most
// kMaxReportedVariants objects, each checked as a /v1/variant body is), at most kMaxRequestBytes, nested at most 4
// deep. The error is the 400 to answer.
Result<SelectedReport, Answer> parse_selected_report(std::string_view body);

}  // namespace kiln::development
