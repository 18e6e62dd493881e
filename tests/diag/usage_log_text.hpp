// SPDX-License-Identifier: Apache-2.0
// A usage log of pack "p", pass "P", in which the game selected the keyword sets given (one keyword each, "" for
// none): shared by the watch and development-endpoint tests.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace kiln::testing {

inline std::string usage_log(const std::vector<std::string>& keyword_sets) {
  nlohmann::json served = nlohmann::json::array();
  for (const std::string& keywords : keyword_sets)
    served.push_back({{"keywords", keywords.empty() ? nlohmann::json::array() : nlohmann::json::array({keywords})}, {"count", 1}});
  return nlohmann::json{{"format", "kiln-usage"}, {"format_version", 1}, {"pack", "p"}, {"tags", nlohmann::json::object()},
                        {"passes", {{{"name", "P"}, {"served", served}, {"missing", nlohmann::json::array()}}}},
                        {"missing_dropped", 0}}
      .dump();
}

}  // namespace kiln::testing
