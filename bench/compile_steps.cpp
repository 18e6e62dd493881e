// Times each step of one compile job on a preprocessed stage source (from `kiln build --emit preprocessed`),
// in the order a worker runs them: front end (glslang), legalize (kiln's core recipe), validate, optimize,
// validate, reflect, the three cross-compilers. Linked with the same allocator as kiln-worker, so the numbers
// are the workers'. SPIRV-Tools' full legalization recipe (the fallback) is timed too, outside the total.
// usage: kiln-compile-steps FILE.hlsl vertex|fragment ENTRY [repetitions] [--json OUT]
#include <algorithm>
#include <chrono>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <string_view>

#include <nlohmann/json.hpp>

#include "../compiler/cli/allocator.hpp"
#include "cross/cross_compile.hpp"
#include "frontend/frontend.hpp"
#include "optimize/spirv_tools.hpp"
#include "reflect/reflect.hpp"

int main(int argc, char** argv) {
  std::vector<std::string_view> args(argv + 1, argv + argc);
  std::string json_out;
  if (auto at = std::find(args.begin(), args.end(), "--json"); at != args.end() && at + 1 != args.end()) {
    json_out = std::string(*(at + 1));
    args.erase(at, at + 2);
  }
  if (args.size() < 3) {
    std::cerr << "usage: kiln-compile-steps FILE.hlsl vertex|fragment ENTRY [repetitions] [--json OUT]\n";
    return 2;
  }
  const std::string path(args[0]), entry(args[2]);
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const std::string source = text.str();
  const kiln::Stage stage = kiln::parse_stage(args[1]).value_or(kiln::Stage::Fragment);
  const int reps = args.size() > 3 ? std::stoi(std::string(args[3])) : 9;
  auto frontend = kiln::make_glslang_frontend();

  using clock = std::chrono::steady_clock;
  std::vector<std::string> names;
  std::vector<std::vector<double>> times;
  auto timed = [&](size_t index, const char* name, const std::function<bool()>& step) {
    if (times.size() <= index) {
      names.push_back(name);
      times.emplace_back();
    }
    auto start = clock::now();
    bool ok = step();
    times[index].push_back(std::chrono::duration<double, std::milli>(clock::now() - start).count());
    if (!ok) {
      std::cerr << "kiln-compile-steps: step '" << name << "' failed on " << path << "\n";
      std::exit(1);
    }
  };
  nlohmann::json words;
  for (int r = 0; r < reps; ++r) {
    kiln::CompileResult front;
    kiln::SpirvStepResult legal, optimized;
    size_t i = 0;
    timed(i++, "front end (glslang)", [&] {
      front = frontend->compile({stage, entry, path, source});
      return front.ok;
    });
    timed(i++, "legalize (core recipe)", [&] { return (legal = kiln::legalize_spirv_core(front.spirv)).ok; });
    timed(i++, "validate", [&] { return kiln::validate_spirv(legal.spirv).ok; });
    timed(i++, "optimize (-O)", [&] { return (optimized = kiln::optimize_spirv(legal.spirv)).ok; });
    timed(i++, "validate again", [&] { return kiln::validate_spirv(optimized.spirv).ok; });
    timed(i++, "reflect", [&] { return !kiln::reflect_spirv(optimized.spirv).is_null(); });
    // As in a worker: the GL module (16-bit floats widened) is made once, inside the first GL step.
    kiln::CrossCompiler cross(optimized.spirv);
    timed(i++, "SPIRV-Cross GLSL 450", [&] { return cross.compile(kiln::Target::Glsl).ok; });
    timed(i++, "SPIRV-Cross GLSL ES 310", [&] { return cross.compile(kiln::Target::Gles).ok; });
    timed(i++, "SPIRV-Cross MSL", [&] { return cross.compile(kiln::Target::Msl).ok; });
    words = {{"front_end", front.spirv.size()}, {"legalized", legal.spirv.size()}, {"optimized", optimized.spirv.size()}};
  }
  // The full recipe, for comparison: what the core recipe saves, and what a module that needs it costs.
  std::vector<double> full_times;
  size_t full_words = 0;
  {
    const kiln::CompileResult front = frontend->compile({stage, entry, path, source});
    for (int r = 0; r < reps; ++r) {
      auto start = clock::now();
      kiln::SpirvStepResult full = kiln::legalize_spirv(front.spirv);
      full_times.push_back(std::chrono::duration<double, std::milli>(clock::now() - start).count());
      full_words = full.spirv.size();
    }
    std::sort(full_times.begin(), full_times.end());
  }
  const double full_median = full_times[full_times.size() / 2];
  words["legalized_full_recipe"] = full_words;
  nlohmann::json steps = nlohmann::json::array();
  double total = 0;
  for (size_t i = 0; i < names.size(); ++i) {
    std::sort(times[i].begin(), times[i].end());
    double median = times[i][times[i].size() / 2];
    total += median;
    steps.push_back({{"step", names[i]}, {"median_ms", median}});
    std::cout << names[i] << ": median " << median << " ms\n";
  }
  std::cout << "sum of medians: " << total << " ms; SPIR-V words: " << words.dump() << "\n";
  std::cout << "legalize, full recipe (the fallback, not in the sum): median " << full_median << " ms\n";
  if (!json_out.empty()) {
    std::ofstream out(json_out);
    out << nlohmann::json{{"source", path}, {"stage", std::string(args[1])}, {"entry", entry}, {"repetitions", reps},
                          {"allocator", kiln::allocator_description()}, {"spirv_words", words}, {"steps", steps},
                          {"total_ms", total}, {"full_legalization_ms", full_median}}
               .dump(2)
        << "\n";
  }
}
