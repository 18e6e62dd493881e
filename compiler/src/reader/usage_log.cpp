// SPDX-License-Identifier: Apache-2.0
#include "kiln/usage_log.hpp"

#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <system_error>

#include <nlohmann/json.hpp>

#include "kiln/output_file.hpp"

namespace kiln::usage_log {

std::string text(std::string_view pack, const std::map<std::string, std::string>& tags, std::vector<Pass> passes,
                 uint64_t missing_dropped) {
  auto requests = [](std::vector<Request>& list, bool missing) {
    for (Request& r : list) {
      std::sort(r.keywords.begin(), r.keywords.end());
      std::sort(r.nearest.begin(), r.nearest.end());
    }
    std::sort(list.begin(), list.end(), [](const Request& a, const Request& b) { return a.keywords < b.keywords; });
    nlohmann::ordered_json json = nlohmann::ordered_json::array();
    for (const Request& r : list) {
      nlohmann::ordered_json entry{{"keywords", r.keywords}, {"count", r.count}};
      if (missing) entry["nearest"] = r.nearest;
      json.push_back(std::move(entry));
    }
    return json;
  };
  nlohmann::ordered_json tag_json = nlohmann::ordered_json::object(), pass_json = nlohmann::ordered_json::array();
  for (const auto& [key, value] : tags) tag_json[key] = value;
  for (Pass& pass : passes)
    pass_json.push_back({{"name", pass.name}, {"served", requests(pass.served, false)}, {"missing", requests(pass.missing, true)}});
  const nlohmann::ordered_json log{{"format", "kiln-usage"}, {"format_version", 1},  {"pack", pack},
                                   {"tags", tag_json},       {"passes", pass_json}, {"missing_dropped", missing_dropped}};
  return log.dump(2) + "\n";
}

Result<void> write_atomically(const std::filesystem::path& file, const std::string& text) {
  if (Result<void> written = write_output_file(file, text); !written)
    return failure("cannot write the usage log: " + written.error().message);
  return {};
}

}  // namespace kiln::usage_log
