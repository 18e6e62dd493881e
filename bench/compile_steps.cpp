// SPDX-License-Identifier: Apache-2.0
// Times the steps of compile jobs on preprocessed stage sources (from `kiln build --emit preprocessed`), in
// the order a worker runs them: front end (glslang), legalize (kiln's core recipe), validate, optimize (kiln's recipe),
// validate, reflect, the three cross-compilers. Linked with the same allocator as kiln-worker, so the numbers
// are the workers'.
//
// One source: each step's median over `repetitions` runs; SPIRV-Tools' full legalization recipe (the
// fallback) is timed too, outside the total.
//   kiln-compile-steps FILE.hlsl vertex|fragment ENTRY [repetitions] [--json OUT]
// The floor of a pack: every source the pack's build compiles, once each, one after the other; back-end
// steps only for the first source of each distinct front-end module, as kiln does. The sum is the library
// work of a cold build, without kiln's own (planning, preprocessing, processes, cache, pack).
//   kiln-compile-steps --floor EMIT_DIR PACK.json [--json OUT]
#include <algorithm>
#include <chrono>
#include <fstream>
#include <functional>
#include <iostream>
#include <set>
#include <sstream>
#include <string_view>

#include <nlohmann/json.hpp>

#include "../compiler/cli/allocator.hpp"
#include "common/hash.hpp"
#include "emitted_sources.hpp"
#include "cross/targets.hpp"
#include "frontend/frontend.hpp"
#include "optimize/spirv_tools.hpp"
#include "reflect/reflect.hpp"

namespace {

using clock_type = std::chrono::steady_clock;

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Step names in order and, per step, the times recorded.
struct StepTimes {
  std::vector<std::string> names;
  std::vector<std::vector<double>> times;
  void record(size_t index, const char* name, double ms) {
    if (names.size() <= index) {
      names.push_back(name);
      times.emplace_back();
    }
    times[index].push_back(ms);
  }
};

// Runs a worker's steps on one source, recording each step's time. Back-end steps only when `back_end`
// says so for the front end's module. Exits on a failed step: every source of a good pack compiles.
nlohmann::json run_steps(kiln::Frontend& frontend, const std::string& path, kiln::Stage stage, const std::string& entry,
                         StepTimes& out, const std::function<bool(const std::vector<uint32_t>&)>& back_end) {
  const std::string source = read_file(path);
  auto timed = [&](size_t index, const char* name, const std::function<bool()>& step) {
    auto start = clock_type::now();
    bool ok = step();
    out.record(index, name, std::chrono::duration<double, std::milli>(clock_type::now() - start).count());
    if (!ok) {
      std::cerr << "kiln-compile-steps: step '" << name << "' failed on " << path << "\n";
      std::exit(1);
    }
  };
  kiln::CompileResult front;
  kiln::SpirvModule legal, optimized;
  // The step's module (its time is what counts here), and whether it succeeded.
  auto took = [](kiln::SpirvModule& into, kiln::SpirvResult result) {
    if (!result) return false;
    into = std::move(*result);
    return true;
  };
  size_t i = 0;
  timed(i++, "front end (glslang)", [&] {
    front = frontend.compile({stage, entry, path, source});
    return front.ok;
  });
  if (!back_end(front.spirv)) return nullptr;
  timed(i++, "legalize (core recipe)", [&] { return took(legal, kiln::legalize_spirv_core(front.spirv)); });
  timed(i++, "validate", [&] { return kiln::validate_spirv(legal.spirv).has_value(); });
  timed(i++, "optimize (kiln's recipe)", [&] {
    return took(optimized, kiln::optimize_spirv(legal.spirv, kiln::OptimizerRecipe::Kiln));
  });
  timed(i++, "validate again", [&] { return kiln::validate_spirv(optimized.spirv).has_value(); });
  // A depth-only vertex stage has no outputs but its position: reflection cannot fail, only take time.
  timed(i++, "reflect", [&] {
    (void)kiln::reflect_spirv(optimized.spirv);
    return true;
  });
  // As in a worker: the GL module (16-bit floats widened) is made once, inside the first GL step.
  kiln::CrossModules modules(optimized.spirv);
  kiln::Reflection records;
  auto cross = [&](kiln::Target target) { return kiln::cross_compile(*kiln::target_backend(target), modules, records).has_value(); };
  timed(i++, "SPIRV-Cross GLSL 450", [&] { return cross(kiln::Target::Glsl); });
  timed(i++, "SPIRV-Cross GLSL ES 310", [&] { return cross(kiln::Target::Gles); });
  timed(i++, "SPIRV-Cross MSL", [&] { return cross(kiln::Target::Msl); });
  return {{"front_end", front.spirv.size()}, {"legalized", legal.spirv.size()}, {"optimized", optimized.spirv.size()}};
}

void write_json(const std::string& path, const nlohmann::json& j) {
  if (path.empty()) return;
  std::ofstream out(path);
  out << j.dump(2) << "\n";
}

int floor_mode(const std::string& emit_dir, const std::string& pack_file, const std::string& json_out) {
  const std::vector<kiln::bench::EmittedSource> sources = kiln::bench::emitted_sources(emit_dir, pack_file);
  auto frontend = kiln::make_glslang_frontend();
  StepTimes steps;
  std::set<std::string> modules;
  size_t front_ends = 0, back_ends = 0;
  // Per source, in build order: its front end's time and, for the first source of each module, the back end's
  // (bench/scaling_model.py schedules these jobs on P workers).
  nlohmann::json jobs = nlohmann::json::array();
  auto recorded_ms = [&] {
    double sum = 0;
    for (const auto& times : steps.times)
      for (double t : times) sum += t;
    return sum;
  };
  const auto start = clock_type::now();
  for (const kiln::bench::EmittedSource& source : sources) {
    ++front_ends;
    const double before = recorded_ms();
    bool fresh = false;
    run_steps(*frontend, source.path.string(), source.stage, source.entry, steps, [&](const std::vector<uint32_t>& spirv) {
      std::string key = source.stage_name + source.entry;
      key.append(reinterpret_cast<const char*>(spirv.data()), spirv.size() * 4);
      fresh = modules.insert(kiln::hash128(key).hex()).second;
      back_ends += fresh;
      return fresh;
    });
    const double front_ms = steps.times[0].back(), all_ms = recorded_ms() - before;
    jobs.push_back({{"stage", source.stage_name}, {"front_end_ms", front_ms}, {"back_end_ms", fresh ? all_ms - front_ms : 0.0}});
  }
  const double wall = std::chrono::duration<double>(clock_type::now() - start).count();
  nlohmann::json table = nlohmann::json::array();
  double total = 0;
  for (size_t i = 0; i < steps.names.size(); ++i) {
    double sum = 0;
    for (double t : steps.times[i]) sum += t;
    total += sum / 1000;
    table.push_back({{"step", steps.names[i]}, {"runs", steps.times[i].size()}, {"total_s", sum / 1000}});
    std::cout << steps.names[i] << ": " << steps.times[i].size() << " runs, " << sum / 1000 << " s\n";
  }
  std::cout << "front ends " << front_ends << ", back ends " << back_ends << ", library time " << total << " s (wall "
            << wall << " s)\n";
  write_json(json_out, {{"pack", pack_file}, {"allocator", kiln::allocator_description()}, {"front_ends", front_ends},
                        {"back_ends", back_ends}, {"steps", table}, {"total_s", total}, {"wall_s", wall}, {"jobs", jobs}});
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string_view> args(argv + 1, argv + argc);
  std::string json_out;
  if (auto at = std::find(args.begin(), args.end(), "--json"); at != args.end() && at + 1 != args.end()) {
    json_out = std::string(*(at + 1));
    args.erase(at, at + 2);
  }
  if (args.size() == 3 && args[0] == "--floor") return floor_mode(std::string(args[1]), std::string(args[2]), json_out);
  if (args.size() < 3) {
    std::cerr << "usage: kiln-compile-steps FILE.hlsl vertex|fragment ENTRY [repetitions] [--json OUT]\n"
                 "       kiln-compile-steps --floor EMIT_DIR PACK.json [--json OUT]\n";
    return 2;
  }
  const std::string path(args[0]), entry(args[2]);
  const kiln::Stage stage = kiln::parse_stage(args[1]).value_or(kiln::Stage::Fragment);
  const int reps = args.size() > 3 ? std::stoi(std::string(args[3])) : 9;
  auto frontend = kiln::make_glslang_frontend();

  StepTimes steps;
  nlohmann::json words;
  for (int r = 0; r < reps; ++r) words = run_steps(*frontend, path, stage, entry, steps, [](const auto&) { return true; });
  // The full recipe, for comparison: what the core recipe saves, and what a module that needs it costs.
  std::vector<double> full_times;
  size_t full_words = 0;
  {
    const kiln::CompileResult front = frontend->compile({stage, entry, path, read_file(path)});
    for (int r = 0; r < reps; ++r) {
      auto start = clock_type::now();
      kiln::SpirvResult full = kiln::legalize_spirv(front.spirv);
      full_times.push_back(std::chrono::duration<double, std::milli>(clock_type::now() - start).count());
      full_words = full ? full->spirv.size() : 0;
    }
    std::sort(full_times.begin(), full_times.end());
  }
  const double full_median = full_times[full_times.size() / 2];
  words["legalized_full_recipe"] = full_words;
  nlohmann::json table = nlohmann::json::array();
  double total = 0;
  for (size_t i = 0; i < steps.names.size(); ++i) {
    std::sort(steps.times[i].begin(), steps.times[i].end());
    double median = steps.times[i][steps.times[i].size() / 2];
    total += median;
    table.push_back({{"step", steps.names[i]}, {"median_ms", median}});
    std::cout << steps.names[i] << ": median " << median << " ms\n";
  }
  std::cout << "sum of medians: " << total << " ms; SPIR-V words: " << words.dump() << "\n";
  std::cout << "legalize, full recipe (the fallback, not in the sum): median " << full_median << " ms\n";
  write_json(json_out, {{"source", path}, {"stage", std::string(args[1])}, {"entry", entry}, {"repetitions", reps},
                        {"allocator", kiln::allocator_description()}, {"spirv_words", words}, {"steps", table},
                        {"total_ms", total}, {"full_legalization_ms", full_median}});
  return 0;
}
