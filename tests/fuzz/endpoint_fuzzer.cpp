// SPDX-License-Identifier: Apache-2.0
// libFuzzer harness: the development endpoint's request bodies (kiln watch --serve; compiler/src/watch/
// development_protocol.cpp), as any local process may send them: each input is given to both parsers, as the body
// of POST /v1/variant and of POST /v1/selected. Findings: a crash, an escaped exception (the parsers return a 400,
// never throw), ASan/UBSan, and a body accepted against the protocol's promises: a name outside its rules, keywords
// unsorted or repeated, more keywords, variants or id bytes than the bounds, or a refusal whose answer is not a
// JSON object with its error.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "kiln/bounded_json.hpp"
#include "watch/development_protocol.hpp"

namespace {

namespace development = kiln::development;

void check(const development::VariantRequest& variant) {
  if (!development::is_protocol_name(variant.pass) || variant.keywords.size() > development::kMaxKeywords) std::abort();
  if (!std::all_of(variant.keywords.begin(), variant.keywords.end(), development::is_protocol_name)) std::abort();
  if (std::adjacent_find(variant.keywords.begin(), variant.keywords.end(), std::greater_equal<>()) != variant.keywords.end())
    std::abort();  // sorted, without repeats
}

void check(const development::Answer& refusal) {
  if (refusal.status != 400 || refusal.body.size() > development::kMaxAnswerBytes) std::abort();
  const nlohmann::json body = kiln::parse_json_bounded(refusal.body, {development::kMaxAnswerBytes, 2});  // throws: a finding
  if (!body.is_object() || !body.contains("error") || !body["error"].is_string()) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view body(reinterpret_cast<const char*>(data), size);
  if (auto variant = development::parse_variant_request(body)) check(*variant);
  else check(variant.error());
  if (auto report = development::parse_selected_report(body)) {
    if (report->client.empty() || report->client.size() > development::kMaxClientBytes ||
        report->selected.size() > development::kMaxReportedVariants)
      std::abort();
    for (const development::VariantRequest& variant : report->selected) check(variant);
  } else {
    check(report.error());
  }
  return 0;
}
