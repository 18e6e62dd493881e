// SPDX-License-Identifier: Apache-2.0
// What each SPIRV-Tools pass does on a pack's modules: for the core legalization recipe (on the front end's
// modules) and for the optimizer recipes (on the legalized ones), runs the recipe one pass at a time and
// records, per pass, how many modules it changed and how long it took; then times each recipe whole, in
// interleaved rounds, and checks that kiln's recipe gives -O's modules (IDs compacted). For the legalization
// recipe, also each pass's marginal cost where it stands (on every fourth module).
//   kiln-optimizer-passes EMIT_DIR PACK.json [--rounds N] [--json OUT]
// EMIT_DIR is `kiln build --emit preprocessed`'s emit directory of PACK.json (as for kiln-compile-steps --floor).
// A pass "changed" a module when its output differs from its input in any word. A pass's time is the time of an
// Optimizer running that pass alone minus the time of one running no pass on the same module (parsing and
// writing the module back), so the per-pass times add up to about the whole recipe's.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <string_view>

#include <nlohmann/json.hpp>
#include <spirv-tools/optimizer.hpp>

#include "../compiler/cli/allocator.hpp"
#include "common/hash.hpp"
#include "emitted_sources.hpp"
#include "frontend/frontend.hpp"
#include "optimize/spirv_tools.hpp"

namespace {

using clock_type = std::chrono::steady_clock;
using Module = std::vector<uint32_t>;

// A step's module; empty when it failed.
Module spirv_of(kiln::SpirvResult result) { return result ? std::move(result->spirv) : Module(); }

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

double ms_since(clock_type::time_point start) {
  return std::chrono::duration<double, std::milli>(clock_type::now() - start).count();
}

// The distinct front-end modules of a pack's build, as kiln compiles them (one per module, not per source).
std::vector<Module> front_end_modules(const std::string& emit_dir, const std::string& pack_file) {
  auto frontend = kiln::make_glslang_frontend();
  std::set<std::string> seen;
  std::vector<Module> modules;
  for (const kiln::bench::EmittedSource& source : kiln::bench::emitted_sources(emit_dir, pack_file)) {
    const std::string text = read_file(source.path);
    kiln::CompileResult front = frontend->compile({source.stage, source.entry, source.path.string(), text});
    if (!front.ok) {
      std::cerr << "kiln-optimizer-passes: the front end failed on " << source.path << "\n";
      std::exit(1);
    }
    std::string key = source.stage_name + source.entry;
    key.append(reinterpret_cast<const char*>(front.spirv.data()), front.spirv.size() * 4);
    if (seen.insert(kiln::hash128(key).hex()).second) modules.push_back(std::move(front.spirv));
  }
  return modules;
}

// Runs `flags` (none: parse and write back only) on `in`.
bool run_flags(const Module& in, const std::vector<std::string>& flags, Module& out) {
  spvtools::Optimizer optimizer(kiln::spirv_tools_environment());
  optimizer.SetMessageConsumer([](spv_message_level_t, const char*, const spv_position_t&, const char*) {});
  if (!optimizer.RegisterPassesFromFlags(flags)) {
    std::cerr << "kiln-optimizer-passes: SPIRV-Tools does not know one of the flags\n";
    std::exit(1);
  }
  spvtools::OptimizerOptions options;
  options.set_run_validator(false);
  return optimizer.Run(in.data(), in.size(), &out, options);
}

// A pass's command-line flag from its name() (they are the same but for the interpolant fix-up).
std::string flag_of(std::string_view name) {
  if (name == "interp-fixup") return "--interpolate-fixup";
  return "--" + std::string(name);
}

struct PassRow {
  std::string name;
  size_t changed = 0;
  double ms = 0;
};

// One pass at a time over every module; `after` gets each module's result. Exits when the pass-by-pass result
// differs from `whole`'s (the recipe in one Optimizer) after ID compaction: the rows would not describe the recipe
// kiln runs.
std::vector<PassRow> pass_by_pass(const std::vector<Module>& inputs, const std::vector<std::string>& names,
                                  const std::function<Module(const Module&)>& whole, const std::string& label,
                                  std::vector<Module>& after) {
  std::vector<PassRow> rows;
  for (const std::string& name : names) rows.push_back({name});
  after.clear();
  for (const Module& input : inputs) {
    Module current = input;
    for (PassRow& row : rows) {
      Module unchanged, next;
      auto start = clock_type::now();
      run_flags(current, {}, unchanged);
      const double baseline = ms_since(start);
      start = clock_type::now();
      if (!run_flags(current, {flag_of(row.name)}, next)) {
        std::cerr << "kiln-optimizer-passes: " << label << ": pass " << row.name << " failed\n";
        std::exit(1);
      }
      row.ms += ms_since(start) - baseline;
      row.changed += next != current;
      current = std::move(next);
    }
    Module reference = whole(input);
    // One Optimizer per pass numbers new IDs differently from one for the whole recipe: the same module
    // otherwise. The next recipe starts from the whole recipe's module, as in kiln.
    if (kiln::compact_ids(current) != kiln::compact_ids(reference)) {
      std::cerr << "kiln-optimizer-passes: " << label << " one pass at a time differs from the whole recipe\n";
      std::exit(1);
    }
    after.push_back(std::move(reference));
  }
  return rows;
}

nlohmann::json rows_json(const std::vector<PassRow>& rows, size_t modules) {
  nlohmann::json table = nlohmann::json::array();
  double total = 0;
  for (size_t i = 0; i < rows.size(); ++i) {
    total += rows[i].ms;
    table.push_back({{"index", i}, {"pass", rows[i].name}, {"changed", rows[i].changed}, {"ms", rows[i].ms}});
    std::cout << "  " << i << " " << rows[i].name << ": changed " << rows[i].changed << " of " << modules << ", "
              << rows[i].ms / 1000 << " s\n";
  }
  std::cout << "  sum " << total / 1000 << " s\n";
  return table;
}

// The marginal cost of each pass in its recipe: the time of the recipe's first k passes, over every module, minus
// that of its first k - 1 (k = 0: parsing and writing back), medians over `rounds` interleaved rounds. Unlike a
// pass run alone, this counts what the pass costs where it is (analyses it shares with its neighbours).
std::vector<double> marginal_seconds(const std::vector<Module>& inputs, const std::vector<std::string>& names, int rounds) {
  std::vector<std::vector<double>> prefix(names.size() + 1);
  for (int r = 0; r < rounds; ++r)
    for (size_t k = 0; k <= names.size(); ++k) {
      std::vector<std::string> flags;
      for (size_t i = 0; i < k; ++i) flags.push_back(flag_of(names[i]));
      Module out;
      auto start = clock_type::now();
      for (const Module& m : inputs) run_flags(m, flags, out);
      prefix[k].push_back(ms_since(start) / 1000);
    }
  std::vector<double> medians;
  for (auto& times : prefix) {
    std::sort(times.begin(), times.end());
    medians.push_back(times[times.size() / 2]);
  }
  std::vector<double> marginal;
  for (size_t k = 1; k < medians.size(); ++k) marginal.push_back(medians[k] - medians[k - 1]);
  marginal.insert(marginal.begin(), medians[0]);  // [0]: parse and write back
  return marginal;
}

Module compacted(const Module& module) {
  Module out;
  run_flags(module, {"--compact-ids"}, out);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  std::string json_out;
  int rounds = 3;
  for (size_t i = 0; i + 1 < args.size();) {
    if (args[i] == "--json") json_out = args[i + 1];
    else if (args[i] == "--rounds") rounds = std::stoi(args[i + 1]);
    else { ++i; continue; }
    args.erase(args.begin() + static_cast<long>(i), args.begin() + static_cast<long>(i) + 2);
  }
  if (args.size() != 2) {
    std::cerr << "usage: kiln-optimizer-passes EMIT_DIR PACK.json [--rounds N] [--json OUT]\n";
    return 2;
  }
  const std::vector<Module> front = front_end_modules(args[0], args[1]);
  std::cout << front.size() << " distinct front-end modules\n";

  std::vector<Module> legalized, stock, kiln_optimized;
  std::cout << "core legalization recipe, one pass at a time:\n";
  const auto legalization_rows = pass_by_pass(front, kiln::legalization_pass_names(),
                                              [](const Module& m) { return spirv_of(kiln::legalize_spirv_core(m)); },
                                              "the core legalization recipe", legalized);
  nlohmann::json legalization_json = rows_json(legalization_rows, front.size());
  // On every fourth module: 17 recipe prefixes over all of them would take longer than the rest together.
  std::vector<Module> sample;
  for (size_t i = 0; i < front.size(); i += 4) sample.push_back(front[i]);
  std::cout << "core legalization recipe, marginal cost of each pass (" << sample.size() << " modules, " << rounds
            << " rounds):\n";
  const std::vector<double> legalization_marginal = marginal_seconds(sample, kiln::legalization_pass_names(), rounds);
  std::cout << "  parse and write back: " << legalization_marginal[0] << " s\n";
  for (size_t i = 0; i < legalization_rows.size(); ++i) {
    legalization_json[i]["marginal_s"] = legalization_marginal[i + 1];
    std::cout << "  " << i << " " << legalization_rows[i].name << ": " << legalization_marginal[i + 1] << " s\n";
  }
  std::cout << "-O, one pass at a time, on the legalized modules:\n";
  const auto stock_rows = pass_by_pass(
      legalized, kiln::optimizer_pass_names(kiln::OptimizerRecipe::Stock),
      [](const Module& m) { return spirv_of(kiln::optimize_spirv(m, kiln::OptimizerRecipe::Stock)); }, "-O", stock);
  nlohmann::json stock_json = rows_json(stock_rows, legalized.size());
  std::cout << "kiln's recipe, one pass at a time, on the legalized modules:\n";
  const auto kiln_rows = pass_by_pass(
      legalized, kiln::optimizer_pass_names(kiln::OptimizerRecipe::Kiln),
      [](const Module& m) { return spirv_of(kiln::optimize_spirv(m, kiln::OptimizerRecipe::Kiln)); }, "kiln's recipe",
      kiln_optimized);
  nlohmann::json kiln_json = rows_json(kiln_rows, legalized.size());

  size_t identical = 0, identical_bytes = 0;
  for (size_t i = 0; i < stock.size(); ++i) {
    identical_bytes += stock[i] == kiln_optimized[i];
    identical += compacted(stock[i]) == compacted(kiln_optimized[i]);
  }
  std::cout << "kiln's recipe against -O: " << identical << " of " << stock.size() << " identical after ID compaction ("
            << identical_bytes << " byte for byte before)\n";

  // Whole recipes, interleaved rounds (each round: legalize, -O, kiln's recipe over every module).
  std::vector<double> legalize_s, stock_s, kiln_s;
  for (int r = 0; r < rounds; ++r) {
    auto time_all = [&](const std::vector<Module>& inputs, auto step) {
      auto start = clock_type::now();
      for (const Module& m : inputs) (void)step(m);
      return ms_since(start) / 1000;
    };
    legalize_s.push_back(time_all(front, [](const Module& m) { return kiln::legalize_spirv_core(m); }));
    stock_s.push_back(time_all(legalized, [](const Module& m) { return kiln::optimize_spirv(m, kiln::OptimizerRecipe::Stock); }));
    kiln_s.push_back(time_all(legalized, [](const Module& m) { return kiln::optimize_spirv(m, kiln::OptimizerRecipe::Kiln); }));
    std::cout << "round " << r + 1 << ": legalize " << legalize_s.back() << " s, -O " << stock_s.back() << " s, kiln's recipe "
              << kiln_s.back() << " s\n";
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  std::cout << "medians: legalize " << median(legalize_s) << " s, -O " << median(stock_s) << " s, kiln's recipe "
            << median(kiln_s) << " s (" << median(stock_s) / median(kiln_s) << "x)\n";
  if (!json_out.empty()) {
    std::ofstream out(json_out);
    out << nlohmann::json{{"pack", args[1]},
                          {"allocator", kiln::allocator_description()},
                          {"spirv_tools", kiln::spirv_tools_version()},
                          {"modules", front.size()},
                          {"legalization_passes", legalization_json},
                          {"legalization_parse_and_write_s", legalization_marginal[0]},
                          {"marginal_sample_modules", sample.size()},
                          {"stock_passes", stock_json},
                          {"kiln_passes", kiln_json},
                          {"identical_after_compaction", identical},
                          {"identical_bytes", identical_bytes},
                          {"rounds", rounds},
                          {"legalize_s", legalize_s},
                          {"stock_s", stock_s},
                          {"kiln_s", kiln_s}}
               .dump(2)
        << "\n";
  }
  return identical == stock.size() ? 0 : 1;
}
