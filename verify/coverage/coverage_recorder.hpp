// SPDX-License-Identifier: Apache-2.0
// Shader code coverage of a test run (docs/coverage.md): which HLSL lines of a --coverage pack the draws ran, by
// which scene and variant first, written as an lcov tracefile (genhtml renders it) and as JSON. The renderers
// bind each pass's coverage buffer, and after each draw hand its words here with the modules that wrote them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "kiln/coverage_map.hpp"
#include "kiln/pack_reader.hpp"

namespace kiln::render {

class CoverageRecorder {
 public:
  // The lines a run can reach: every line of every instrumented SPIR-V module of the pack. A keyword the pack
  // strips has no module, so its lines count neither as hit nor as missed. Throws a VerifyError (K2004) when no
  // module of the pack is instrumented (it was built without --coverage) or a module's map is malformed.
  CoverageRecorder(const PackReader& pack, const std::filesystem::path& pack_dir);

  // The scene and variant of the draws that follow (the first to light a line is recorded).
  void set_witness(std::string witness) { witness_ = std::move(witness); }
  const std::string& witness() const { return witness_; }

  // After a draw: `words` is the pass's coverage buffer, written by the stages of `modules` (SPIR-V bytes of this
  // pack). Each line whose probe is set counts one hit (once per call), and the probes' words are cleared for the
  // next draw. A module that is not instrumented is skipped. `role` follows the witness ("(shadow caster)").
  void credit(const std::vector<std::string_view>& modules, uint32_t* words, size_t word_count, std::string_view role = {});

  struct Totals {
    size_t files = 0, lines = 0, hit = 0;
  };
  Totals totals() const;
  // "kiln test: coverage 812/845 lines (96.1%) in 11 files"
  std::string summary() const;
  // lcov's tracefile format (geninfo(1)): TN, then per file SF, FN and FNDA per function, FNF, FNH, DA per line,
  // LF, LH, end_of_record. The modules name files as kiln build showed them (relative to where it ran): a name
  // that is a file from the current directory is written absolute, so genhtml finds the sources wherever it runs;
  // any other as it is. Function records need the source (coverage/hlsl_functions.hpp): a file that cannot be read
  // from the current directory has line records only.
  void write_lcov(const std::filesystem::path& path, const std::string& test_name) const;
  // {"test": ..., "files": {file: {line: {"hits": n, "first": witness}}}}, dark lines with hits 0 and no "first".
  void write_json(const std::filesystem::path& path, const std::string& test_name) const;

 private:
  // A function of a source file with at least one instrumented line: it counts one hit per credit() in which any
  // of its lines ran, as a line does.
  struct Function {
    std::string name;  // unique in its file: a name defined twice (an #if per precision) says its line
    uint32_t first_line = 0;
    uint64_t hits = 0;
  };
  struct Line {
    uint64_t hits = 0;
    std::string first;
    Function* function = nullptr;
  };
  struct Module {
    std::vector<uint32_t> words;             // each probe's word
    std::vector<std::vector<Line*>> lines;   // each probe's lines
  };
  const Module* module_for(std::string_view spirv);
  void find_functions();


  std::map<std::string, std::map<uint32_t, Line>> files_;
  std::map<std::string, std::vector<Function>> functions_;  // by file, in line order; never resized after construction
  std::map<std::pair<size_t, size_t>, Module> modules_;  // by (size, hash) of the module's bytes
  std::string witness_;
};

}  // namespace kiln::render
