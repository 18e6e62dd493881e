// SPDX-License-Identifier: Apache-2.0
#include "coverage/coverage_recorder.hpp"

#include <cctype>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <functional>
#include <optional>
#include <set>

#include <nlohmann/json.hpp>

#include "coverage/hlsl_functions.hpp"
#include "scene/image.hpp"
#include "scene/verify_error.hpp"

namespace kiln::render {
namespace {

std::pair<size_t, size_t> module_key(std::string_view spirv) { return {spirv.size(), std::hash<std::string_view>{}(spirv)}; }

// The pack names its sources (a damaged or hostile one may name anything): only a regular file, and only so much
// of it, is read; a shader library file is under a megabyte.
constexpr std::streamsize kMaxSourceBytes = std::streamsize{16} << 20;

std::optional<std::string> read_source(const std::string& name) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(name, ec)) return std::nullopt;
  std::ifstream in(name, std::ios::binary);
  std::string text(static_cast<size_t>(kMaxSourceBytes) + 1, '\0');
  in.read(text.data(), kMaxSourceBytes + 1);
  if (in.bad() || in.gcount() > kMaxSourceBytes) return std::nullopt;
  text.resize(static_cast<size_t>(in.gcount()));
  return text;
}

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
  find_functions();
}

// Each instrumented line is credited to the function whose lines hold it; a function none of whose lines has a
// probe (stripped by every variant, or never called) is not listed, as such lines are not.
void CoverageRecorder::find_functions() {
  for (auto& [file, lines] : files_) {
    const std::optional<std::string> text = read_source(file);
    if (!text) continue;
    const std::vector<HlslFunction> defined = hlsl_functions(*text);
    std::map<std::string, int> uses;
    for (const HlslFunction& f : defined) ++uses[f.name];
    std::vector<Function>& functions = functions_[file];
    functions.reserve(defined.size());  // the lines point into it
    for (const HlslFunction& f : defined) {
      auto line = lines.lower_bound(f.first_line);
      if (line == lines.end() || line->first > f.last_line) continue;
      Function& function = functions.emplace_back();
      function.name = uses[f.name] > 1 ? f.name + " (line " + std::to_string(f.first_line) + ")" : f.name;
      function.first_line = f.first_line;
      for (; line != lines.end() && line->first <= f.last_line; ++line) line->second.function = &function;
    }
    if (functions.empty()) functions_.erase(file);
  }
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
  std::set<Function*> entered;
  for (Line* line : lit) {
    if (line->hits++ == 0) line->first = role.empty() ? witness_ : witness_ + " " + std::string(role);
    if (line->function) entered.insert(line->function);
  }
  for (Function* function : entered) ++function->hits;
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
    if (auto functions = functions_.find(file); functions != functions_.end()) {
      size_t entered = 0;
      for (const Function& f : functions->second) out << "FN:" << f.first_line << "," << f.name << "\n";
      for (const Function& f : functions->second) {
        out << "FNDA:" << f.hits << "," << f.name << "\n";
        if (f.hits) ++entered;
      }
      out << "FNF:" << functions->second.size() << "\nFNH:" << entered << "\n";
    }
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
