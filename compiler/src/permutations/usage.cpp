// SPDX-License-Identifier: Apache-2.0
#include "permutations/usage.hpp"

#include <algorithm>
#include <limits>
#include <set>

#include <nlohmann/json.hpp>

#include "kiln/bounded_json.hpp"
#include "kiln/defaults.hpp"
#include "kiln/pack_format.hpp"
#include "kiln/text.hpp"
#include "kiln/usage_log.hpp"

namespace kiln {
namespace {

using nlohmann::json;

// The problems a log reports before the rest are only counted: a 4 MiB log of 40,000 unknown keys is 20 errors and
// one line for the rest, not 40,000 (each located by a search of the text and quoted by the sink).
constexpr size_t kMaxLogProblemsShown = 20;

// A problem in a log, at the field it is about (the file's start when the field cannot be found).
struct LogReader {
  const std::filesystem::path& file;
  const std::string& text;
  DiagnosticSink& sink;
  bool ok = true;
  size_t shown = 0, not_shown = 0;
  std::vector<size_t> line_starts;  // made on the first problem located: each then costs a search, not a count

  void fail(std::string_view key, const std::string& message) {
    ok = false;
    if (shown == kMaxLogProblemsShown) {
      ++not_shown;
      return;
    }
    ++shown;
    sink.report(DiagId::UsageLog, locate(key), message);
  }
  // After the last problem: how many were not shown.
  void finish() {
    if (not_shown > 0)
      sink.report(DiagId::UsageLog, SourceLocation{file.string(), 1, 1},
                  "... and " + std::to_string(not_shown) + " more problems in this usage log (the first " +
                      std::to_string(kMaxLogProblemsShown) + " are shown)");
  }
  SourceLocation locate(std::string_view key) {
    const size_t at = key.empty() ? std::string::npos : text.find("\"" + std::string(key) + "\"");
    if (at == std::string::npos) return SourceLocation{file.string(), 1, 1};
    if (line_starts.empty()) {
      line_starts.push_back(0);
      for (size_t i = 0; i < text.size(); ++i)
        if (text[i] == '\n') line_starts.push_back(i + 1);
    }
    // The key's first character, as location_of_offset counts: lines and columns from 1, columns in bytes.
    const size_t offset = at + 1;
    const auto line = std::upper_bound(line_starts.begin(), line_starts.end(), offset) - 1;
    return SourceLocation{file.string(), static_cast<int>(line - line_starts.begin() + 1), static_cast<int>(offset - *line + 1)};
  }
  // A sorted, duplicate-free list of strings.
  std::optional<std::vector<std::string>> keywords(const json& value, std::string_view key) {
    if (!value.is_array()) {
      fail(key, "\"" + std::string(key) + "\" must be an array of keyword names");
      return std::nullopt;
    }
    std::vector<std::string> out;
    for (const json& k : value) {
      if (!k.is_string()) {
        fail(key, "\"" + std::string(key) + "\" must be an array of keyword names");
        return std::nullopt;
      }
      out.push_back(k.get<std::string>());
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
};

// Group value index per group for a keyword set (the group's off value when it names none of the group), or nothing
// when a keyword is not declared by the pass or two name one group.
std::optional<std::vector<uint16_t>> choice_of(const PassKeywords& pass, const std::vector<std::string>& keywords) {
  std::vector<int> chosen(pass.groups.size(), -1);
  for (const std::string& keyword : keywords) {
    bool found = false;
    for (size_t g = 0; g < pass.groups.size() && !found; ++g) {
      const int index = pass.groups[g].index_of(keyword);
      if (index < 0) continue;
      if (chosen[g] >= 0) return std::nullopt;
      chosen[g] = index;
      found = true;
    }
    if (!found) return std::nullopt;
  }
  std::vector<uint16_t> choice(pass.groups.size());
  for (size_t g = 0; g < pass.groups.size(); ++g) {
    if (chosen[g] < 0) chosen[g] = pass.groups[g].values.size() == 1 ? 0 : pass.groups[g].index_of("");
    if (chosen[g] < 0) return std::nullopt;  // a group with no off value the set does not name
    choice[g] = static_cast<uint16_t>(chosen[g]);
  }
  return choice;
}

size_t groups_apart(const std::vector<uint16_t>& a, const std::vector<uint16_t>& b) {
  size_t apart = 0;
  for (size_t g = 0; g < a.size(); ++g) apart += a[g] != b[g];
  return apart;
}

// The log's fields into `log`; false where what follows cannot be read (each problem reported to `reader`).
bool read_usage_log(const json& root, UsageLog& log, LogReader& reader) {
  if (!root.is_object() || root.value("format", json()) != "kiln-usage") {
    reader.fail("format", "not a kiln usage log (its \"format\" must be \"kiln-usage\")");
    return false;
  }
  if (root.value("format_version", json()) != 1) {
    reader.fail("format_version", "usage log format version " + root.value("format_version", json()).dump() +
                                      " is not supported (this kiln reads version 1)");
    return false;
  }
  for (const auto& [key, value] : root.items())
    if (key != "format" && key != "format_version" && key != "pack" && key != "tags" && key != "passes" && key != "missing_dropped")
      reader.fail(key, "unknown field \"" + echoed(key) + "\" in the usage log");
  if (const auto pack = root.find("pack"); pack == root.end() || !pack->is_string()) {
    reader.fail("pack", "missing or wrong field \"pack\": the pack's name");
  } else {
    log.pack = pack->get<std::string>();
    // A merged log's pack is named again in files (the log, a pack built from it): held to the rule of every name.
    if (std::string problem = name_problem(log.pack); !problem.empty())
      reader.fail("pack", "\"pack\": '" + echoed(log.pack) + "' is not a pack name: it " + problem);
  }
  const json tags = root.value("tags", json::object());
  if (!tags.is_object()) reader.fail("tags", "\"tags\" must be an object of strings");
  for (const auto& [key, value] : tags.items()) {
    if (value.is_string()) log.tags[key] = value.get<std::string>();
    else reader.fail(key, "tag \"" + echoed(key) + "\" must be a string");
  }
  const json dropped = root.value("missing_dropped", json(0));
  if (dropped.is_number_unsigned()) log.missing_dropped = dropped.get<uint64_t>();
  else if (!(dropped.is_number_integer() && dropped.get<int64_t>() == 0)) reader.fail("missing_dropped", "\"missing_dropped\" must be a count");
  const json passes = root.value("passes", json());
  if (!passes.is_array()) {
    reader.fail("passes", "missing or wrong field \"passes\": an array of passes");
    return false;
  }
  for (const json& pass : passes) {
    if (!pass.is_object() || !pass.value("name", json()).is_string()) {
      reader.fail("passes", "each pass must be an object with a \"name\"");
      continue;
    }
    std::vector<UsageRequest>& requests = log.passes[pass["name"].get<std::string>()];
    for (const char* list : {"served", "missing"}) {
      const json entries = pass.value(list, json::array());
      if (!entries.is_array()) {
        reader.fail(list, "\"" + std::string(list) + "\" must be an array");
        continue;
      }
      for (const json& entry : entries) {
        if (!entry.is_object() || !entry.value("count", json()).is_number_unsigned() || entry["count"].get<uint64_t>() == 0) {
          reader.fail(list, "each request must be an object with \"keywords\" and a \"count\" of at least 1");
          continue;
        }
        UsageRequest request;
        request.count = entry["count"].get<uint64_t>();
        request.missing = std::string(list) == "missing";
        auto keywords = reader.keywords(entry.value("keywords", json()), "keywords");
        if (!keywords) continue;
        request.keywords = std::move(*keywords);
        if (request.missing && entry.contains("nearest"))
          if (auto nearest = reader.keywords(entry["nearest"], "nearest")) request.nearest = std::move(*nearest);
        requests.push_back(std::move(request));
      }
    }
  }
  return true;
}

}  // namespace

std::optional<UsageLog> load_usage_log(const std::filesystem::path& file, const ReadLimits& limits, DiagnosticSink& sink) {
  auto text = read_text_file(file, limits, sink, SourceLocation{file.string(), 0, 0});
  if (!text) return std::nullopt;
  json root;
  try {
    root = parse_json_bounded(*text, {text->size(), kMaxJsonDepth});
  } catch (const JsonDecodeError& error) {
    sink.report(DiagId::JsonSyntax, location_of_offset(file.string(), *text, error.offset()),
                std::string("invalid JSON: ") + error.what());
    return std::nullopt;
  }
  UsageLog log;
  log.file = file;
  log.text = *text;
  LogReader reader{file, log.text, sink};
  const bool read = read_usage_log(root, log, reader);
  reader.finish();
  if (!read || !reader.ok) return std::nullopt;
  return log;
}



bool usage_matches(const UsageLog& log, const std::vector<std::pair<std::string, std::string>>& filters) {
  return std::all_of(filters.begin(), filters.end(), [&](const auto& filter) {
    auto it = log.tags.find(filter.first);
    return it != log.tags.end() && it->second == filter.second;
  });
}

bool strip_by_usage(const PassKeywords& pass, const std::string& pass_name, PassExpansion& expansion,
                    const std::vector<UsageLog>& logs, unsigned margin, std::vector<StripLine>& strip,
                    DiagnosticSink& sink) {
  const std::string before = expansion.kept.text();
  // Per log, the choice vectors it asked for in this pass (a set the pass cannot express, from a pack that has
  // changed since the run, matches nothing).
  std::vector<std::vector<std::vector<uint16_t>>> asked(logs.size());
  bool mentioned = false;
  for (size_t l = 0; l < logs.size(); ++l) {
    auto it = logs[l].passes.find(pass_name);
    if (it == logs[l].passes.end()) continue;
    mentioned = true;
    for (const UsageRequest& request : it->second)
      if (auto choice = choice_of(pass, request.keywords)) asked[l].push_back(std::move(*choice));
  }
  if (!mentioned) {
    strip.push_back({pass_name, "usage (" + counted(logs.size(), "log") + ")", before + " -> " + before,
                     "no log records a request of this pass: kept whole"});
    return true;
  }
  // What a run asked for that this pack cannot keep, whatever the logs say: a set the pass cannot express (a keyword
  // it does not declare, two of one group), or one its constraints, materials or scenes strip. A warning here, so the
  // build says what it drops (check-usage says it again of the pack); at most kMaxLogProblemsShown a build.
  {
    std::set<std::vector<uint16_t>> expanded;
    for (const Variant& variant : expansion.variants) expanded.insert(variant.choice);
    std::set<std::vector<std::string>> said;  // a set several logs asked for is said once, at the first
    size_t shown = 0, not_shown = 0;
    for (const UsageLog& log : logs) {
      auto it = log.passes.find(pass_name);
      if (it == log.passes.end()) continue;
      for (const UsageRequest& request : it->second) {
        const std::optional<std::vector<uint16_t>> choice = choice_of(pass, request.keywords);
        if ((choice && expanded.count(*choice)) || !said.insert(request.keywords).second) continue;
        if (shown == kMaxLogProblemsShown) {
          ++not_shown;
          continue;
        }
        ++shown;
        sink.report(DiagId::UsageStripped, SourceLocation{log.file.string(), 0, 0},
                    "pass '" + pass_name + "': " + keyword_set_text(request.keywords) + ", asked for " +
                        counted(request.count, "time") + (request.missing ? " (and missing from the pack the run used)" : "") +
                        (choice ? ", is stripped by this pack's constraints, materials or scenes"
                                : ", is a keyword set this pass cannot express (a keyword it does not declare, or two of one group)") +
                        ": the pack built from this log lacks it, and a reader asking for it gets its nearest variant");
      }
    }
    if (not_shown > 0)
      sink.report(DiagId::UsageStripped, SourceLocation{logs.front().file.string(), 0, 0},
                  "pass '" + pass_name + "': ... and " + counted(not_shown, "more keyword set") + " the pack lacks (the first " +
                      std::to_string(kMaxLogProblemsShown) + " are shown)");
  }
  auto wanted_by = [&](const Variant& variant, size_t l) {
    return std::any_of(asked[l].begin(), asked[l].end(),
                       [&](const std::vector<uint16_t>& choice) { return groups_apart(choice, variant.choice) <= margin; });
  };
  for (size_t l = 0; l < logs.size(); ++l) {
    const size_t alone = static_cast<size_t>(std::count_if(expansion.variants.begin(), expansion.variants.end(),
                                                           [&](const Variant& v) { return wanted_by(v, l); }));
    strip.push_back({pass_name, "usage log " + logs[l].file.filename().string() + " (" + counted(asked[l].size(), "keyword set") +
                                    (margin ? ", margin " + std::to_string(margin) : "") + ")",
                     before + " -> " + std::to_string(alone), "variants this run did not ask for"});
  }
  std::vector<Variant> kept;
  for (const Variant& variant : expansion.variants) {
    bool wanted = false;
    for (size_t l = 0; l < logs.size() && !wanted; ++l) wanted = wanted_by(variant, l);
    if (wanted) kept.push_back(variant);
  }
  if (logs.size() > 1)
    strip.push_back({pass_name, "usage (" + counted(logs.size(), "log") + ")", before + " -> " + std::to_string(kept.size()),
                     "variants no run asked for"});
  if (kept.empty()) {
    sink.report(DiagId::NoVariants, SourceLocation{logs.front().file.string(), 0, 0},
                "the usage logs ask for no variant of pass '" + pass_name + "' that the pack has (was the pack changed "
                "since the runs?)");
    return false;
  }
  expansion.variants = std::move(kept);
  expansion.kept = VariantCount{expansion.variants.size(), false};
  return true;
}

std::vector<UsageLog> load_usage_logs(const std::vector<std::string>& files,
                                      const std::vector<std::pair<std::string, std::string>>& filters,
                                      DiagnosticSink& sink, size_t* without_tags) {
  std::vector<UsageLog> logs;
  const ReadLimits limits{defaults::kMaxFileBytes};
  for (const std::string& file : files) {
    std::optional<UsageLog> log = load_usage_log(file, limits, sink);
    if (!log) continue;
    if (usage_matches(*log, filters)) logs.push_back(std::move(*log));
    else if (without_tags) ++*without_tags;
  }
  return logs;
}

SourceLocation usage_log_pack_location(const UsageLog& log) {
  SourceLocation at = locate_json_string(log.file.string(), log.text, "pack");
  return at.line == 0 ? SourceLocation{log.file.string(), 1, 1} : at;
}

std::optional<UsageMerge> merge_usage_logs(const std::vector<UsageLog>& logs, const std::set<std::string>& passes,
                                           DiagnosticSink& sink) {
  if (logs.empty()) return std::nullopt;
  for (const UsageLog& log : logs)
    if (log.pack != logs.front().pack) {
      sink.report(DiagId::UsageLog, usage_log_pack_location(log),
                  "this usage log is of pack '" + echoed(log.pack) + "', the first log (" + logs.front().file.string() +
                      ") of '" + echoed(logs.front().pack) + "': logs of different packs cannot be merged");
      return std::nullopt;
    }
  // Counts from hostile logs cannot wrap: they stop at the largest count.
  constexpr uint64_t kMax = std::numeric_limits<uint64_t>::max();
  auto add = [](uint64_t& total, uint64_t count) { total = count > kMax - total ? kMax : total + count; };
  std::map<std::string, std::string> tags = logs.front().tags;
  uint64_t dropped = 0;
  struct Counts {
    std::map<std::vector<std::string>, uint64_t> served;
    std::map<std::vector<std::string>, std::pair<uint64_t, std::vector<std::string>>> missing;  // count, nearest
  };
  std::map<std::string, Counts> by_pass;
  for (const UsageLog& log : logs) {
    std::erase_if(tags, [&](const auto& tag) {
      auto it = log.tags.find(tag.first);
      return it == log.tags.end() || it->second != tag.second;
    });
    add(dropped, log.missing_dropped);
    for (const auto& [name, requests] : log.passes) {
      if (!passes.empty() && !passes.count(name)) continue;
      Counts& counts = by_pass[name];
      for (const UsageRequest& r : requests) {
        if (!r.missing) {
          add(counts.served[r.keywords], r.count);
          continue;
        }
        auto [it, inserted] = counts.missing.try_emplace(r.keywords, 0, r.nearest);
        add(it->second.first, r.count);
      }
    }
  }
  UsageMerge merge;
  std::vector<usage_log::Pass> out;
  for (auto& [name, counts] : by_pass) {
    usage_log::Pass& pass = out.emplace_back();
    pass.name = name;
    for (auto& [keywords, count] : counts.served) {
      pass.served.push_back({keywords, count, {}});
      add(merge.selections, count);
    }
    for (auto& [keywords, entry] : counts.missing) {
      pass.missing.push_back({keywords, entry.first, entry.second});
      add(merge.selections, entry.first);
    }
    merge.sets += pass.served.size() + pass.missing.size();
  }
  merge.passes = out.size();
  merge.text = usage_log::text(logs.front().pack, tags, std::move(out), dropped);
  return merge;
}

}  // namespace kiln
