// SPDX-License-Identifier: Apache-2.0
#include "watch/development_protocol.hpp"

#include <algorithm>
#include <set>

#include <nlohmann/json.hpp>

#include "kiln/bounded_json.hpp"

namespace kiln::development {
namespace {

Failure<Answer> bad_request(const std::string& message) { return failure(error_answer(400, message)); }

bool is_client_id(const std::string& text) {
  if (text.empty() || text.size() > kMaxClientBytes) return false;
  return std::all_of(text.begin(), text.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
  });
}

// One variant object, {"pass": name, "keywords": [names]}: the same checks for a request and a report's entry.
Result<VariantRequest, Answer> variant_of(const nlohmann::json& json) {
  if (!json.is_object()) return bad_request("a variant must be a JSON object with \"pass\" and \"keywords\"");
  for (const auto& [key, value] : json.items())
    if (key != "pass" && key != "keywords") return bad_request("unknown field in a variant (fields: pass, keywords)");
  const auto pass = json.find("pass");
  if (pass == json.end() || !pass->is_string() || !is_protocol_name(pass->get_ref<const std::string&>()))
    return bad_request("\"pass\" must be a pass name (1 to " + std::to_string(kMaxNameBytes) +
                       " printable ASCII characters)");
  const auto keywords = json.find("keywords");
  if (keywords != json.end() && !keywords->is_array()) return bad_request("\"keywords\" must be an array of keyword names");
  std::set<std::string> names;
  if (keywords != json.end()) {
    if (keywords->size() > kMaxKeywords) return bad_request("at most " + std::to_string(kMaxKeywords) + " keywords in a variant");
    for (const nlohmann::json& keyword : *keywords) {
      if (!keyword.is_string() || !is_protocol_name(keyword.get_ref<const std::string&>()))
        return bad_request("\"keywords\" must be an array of keyword names (1 to " + std::to_string(kMaxNameBytes) +
                           " printable ASCII characters each)");
      names.insert(keyword.get<std::string>());
    }
  }
  return VariantRequest{pass->get<std::string>(), {names.begin(), names.end()}};
}

Result<nlohmann::json, Answer> object_of(std::string_view body, size_t depth) {
  nlohmann::json json;
  try {
    json = parse_json_bounded(body, {kMaxRequestBytes, depth});
  } catch (const JsonDecodeError& error) {
    return bad_request(std::string("the request is not JSON: ") + error.what());
  }
  if (!json.is_object()) return bad_request("the request must be a JSON object");
  return json;
}

}  // namespace

Answer error_answer(unsigned status, const std::string& message, const std::string& diagnostics) {
  nlohmann::json body{{"version", 1}, {"error", message.substr(0, kMaxAnswerBytes / 4)}};
  if (!diagnostics.empty()) body["diagnostics"] = diagnostics.substr(0, kMaxAnswerBytes / 2);
  return {status, body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)};
}

bool is_protocol_name(std::string_view text) {
  if (text.empty() || text.size() > kMaxNameBytes) return false;
  return std::all_of(text.begin(), text.end(), [](char c) { return c > ' ' && c < 0x7f && c != '"' && c != '\\'; });
}

Result<VariantRequest, Answer> parse_variant_request(std::string_view body) {
  Result<nlohmann::json, Answer> json = object_of(body, 3);
  if (!json) return failure(json.error());
  return variant_of(*json);
}

Result<SelectedReport, Answer> parse_selected_report(std::string_view body) {
  Result<nlohmann::json, Answer> json = object_of(body, 4);
  if (!json) return failure(json.error());
  for (const auto& [key, value] : json->items())
    if (key != "client" && key != "selected") return bad_request("unknown field in the report (fields: client, selected)");
  const auto client = json->find("client");
  if (client == json->end() || !client->is_string() || !is_client_id(client->get_ref<const std::string&>()))
    return bad_request("\"client\" must be a reader's id (1 to " + std::to_string(kMaxClientBytes) +
                       " of A-Z, a-z, 0-9, '.', '_' and '-')");
  const auto selected = json->find("selected");
  if (selected == json->end() || !selected->is_array()) return bad_request("\"selected\" must be an array of variants");
  if (selected->size() > kMaxReportedVariants)
    return bad_request("at most " + std::to_string(kMaxReportedVariants) + " variants in a report");
  SelectedReport report{client->get<std::string>(), {}};
  for (const nlohmann::json& entry : *selected) {
    Result<VariantRequest, Answer> variant = variant_of(entry);
    if (!variant) return failure(variant.error());
    report.selected.push_back(std::move(*variant));
  }
  return report;
}

}  // namespace kiln::development
