#include "coverage/coverage_recorder.hpp"

#include <cctype>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <functional>
#include <set>

#include <nlohmann/json.hpp>

#include "scene/image.hpp"
#include "scene/verify_error.hpp"

namespace kiln::render {
namespace {

std::pair<size_t, size_t> module_key(std::string_view spirv) { return {spirv.size(), std::hash<std::string_view>{}(spirv)}; }

}  // namespace

CoverageRecorder::CoverageRecorder(const PackReader& pack, const std::filesystem::path& pack_dir) {
  const Manifest& manifest = pack.manifest();
  for (size_t b = 0; b < manifest.binaries.size(); ++b) {
    auto spirv = manifest.binaries[b].blobs.find(Target::Spirv);
    if (spirv == manifest.binaries[b].blobs.end()) continue;
    const std::string_view bytes = pack.blob(spirv->second);
    Result<std::optional<CoverageMap>> map = read_coverage_map(bytes);
    if (!map) fail(DiagId::PackUnusable, pack_dir, "binary " + std::to_string(b) + "'s coverage map: " + map.error().message);
    if (!*map) continue;
    Module& module = modules_[module_key(bytes)];
    if (!module.words.empty()) continue;
    for (const CoverageProbe& probe : (*map)->probes) {
      module.words.push_back(probe.word);
      module.lines.emplace_back();
      for (const auto& [file, line] : probe.lines) module.lines.back().push_back(&files_[(*map)->files[file]][line]);
    }
  }
  if (modules_.empty())
    fail(DiagId::PackUnusable, pack_dir, "no module of the pack records coverage: build it with kiln build --coverage");
}

const CoverageRecorder::Module* CoverageRecorder::module_for(std::string_view spirv) {
  auto found = modules_.find(module_key(spirv));
  return found == modules_.end() ? nullptr : &found->second;
}

void CoverageRecorder::credit(const std::vector<std::string_view>& modules, uint32_t* words, size_t word_count,
                              std::string_view role) {
  std::set<Line*> lit;
  for (std::string_view spirv : modules) {
    const Module* module = module_for(spirv);
    if (!module) continue;
    for (size_t p = 0; p < module->words.size(); ++p) {
      const uint32_t word = module->words[p];
      if (word >= word_count || words[word] == 0) continue;
      words[word] = 0;
      lit.insert(module->lines[p].begin(), module->lines[p].end());
    }
  }
  for (Line* line : lit) {
    if (line->hits++ == 0) line->first = role.empty() ? witness_ : witness_ + " " + std::string(role);
  }
}

CoverageRecorder::Totals CoverageRecorder::totals() const {
  Totals t;
  t.files = files_.size();
  for (const auto& [file, lines] : files_)
    for (const auto& [number, line] : lines) {
      ++t.lines;
      if (line.hits) ++t.hit;
    }
  return t;
}

std::string CoverageRecorder::summary() const {
  const Totals t = totals();
  char percent[32];
  std::snprintf(percent, sizeof percent, "%.1f%%", t.lines ? 100.0 * double(t.hit) / double(t.lines) : 0.0);
  return "coverage " + std::to_string(t.hit) + "/" + std::to_string(t.lines) + " lines (" + percent + ") in " +
         std::to_string(t.files) + " files";
}

void CoverageRecorder::write_lcov(const std::filesystem::path& path, const std::string& test_name) const {
  std::ostringstream out;
  // lcov's test names are word characters only.
  std::string name;
  for (char c : test_name) name.push_back(std::isalnum(static_cast<unsigned char>(c)) ? c : '_');
  out << "TN:" << name << "\n";
  for (const auto& [file, lines] : files_) {
    // A name relative to where kiln build ran, made absolute when the file is there (genhtml reads the sources).
    std::error_code ec;
    const std::filesystem::path source(file);
    const bool here = source.is_relative() && std::filesystem::is_regular_file(source, ec);
    out << "SF:" << (here ? std::filesystem::absolute(source, ec).lexically_normal().string() : file) << "\n";
    size_t hit = 0;
    for (const auto& [number, line] : lines) {
      out << "DA:" << number << "," << line.hits << "\n";
      if (line.hits) ++hit;
    }
    out << "LF:" << lines.size() << "\nLH:" << hit << "\nend_of_record\n";
  }
  write_output(path, std::move(out).str());
}

void CoverageRecorder::write_json(const std::filesystem::path& path, const std::string& test_name) const {
  nlohmann::ordered_json files = nlohmann::ordered_json::object();
  for (const auto& [file, lines] : files_) {
    nlohmann::ordered_json entry = nlohmann::ordered_json::object();
    for (const auto& [number, line] : lines) {
      nlohmann::ordered_json l{{"hits", line.hits}};
      if (line.hits) l["first"] = line.first;
      entry[std::to_string(number)] = std::move(l);
    }
    files[file] = std::move(entry);
  }
  write_output(path, nlohmann::ordered_json{{"test", test_name}, {"files", std::move(files)}}.dump(1) + "\n");
}

}  // namespace kiln::render
