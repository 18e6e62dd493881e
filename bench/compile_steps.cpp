// Times each step of one compile job on a preprocessed stage source (from `kiln build --emit preprocessed`):
// front end, legalization, validation, optimization, validation, the three cross-compilers, reflection.
// usage: kiln-compile-steps FILE.hlsl vertex|fragment ENTRY [repetitions]
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include "cross/cross_compile.hpp"
#include "frontend/frontend.hpp"
#include "optimize/spirv_tools.hpp"
#include "reflect/reflect.hpp"

int main(int argc, char** argv) {
  if (argc < 4) {
    std::cerr << "usage: kiln-compile-steps FILE.hlsl vertex|fragment ENTRY [repetitions]\n";
    return 2;
  }
  std::ifstream in(argv[1]);
  std::stringstream text;
  text << in.rdbuf();
  std::string source = text.str();
  kiln::Stage stage = kiln::parse_stage(argv[2]).value_or(kiln::Stage::Fragment);
  int reps = argc > 4 ? std::stoi(argv[4]) : 9;
  auto frontend = kiln::make_glslang_frontend();
  std::map<std::string, std::vector<double>> times;
  using clock = std::chrono::steady_clock;
  auto ms = [](clock::time_point a, clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
  for (int r = 0; r < reps; ++r) {
    auto t0 = clock::now();
    kiln::CompileResult compiled = frontend->compile({stage, argv[3], argv[1], source});
    auto t1 = clock::now();
    if (!compiled.ok) {
      std::cerr << "compile failed\n";
      return 1;
    }
    auto legal = kiln::legalize_validate_optimize(compiled.spirv, false);
    auto t2 = clock::now();
    auto full = kiln::legalize_validate_optimize(compiled.spirv, true);
    auto t3 = clock::now();
    auto glsl = kiln::cross_compile(full.spirv, kiln::Target::Glsl, stage);
    auto t4 = clock::now();
    auto gles = kiln::cross_compile(full.spirv, kiln::Target::Gles, stage);
    auto t5 = clock::now();
    auto msl = kiln::cross_compile(full.spirv, kiln::Target::Msl, stage);
    auto t6 = clock::now();
    auto reflection = kiln::reflect_spirv(full.spirv);
    auto t7 = clock::now();
    auto validated = kiln::validate_spirv(legal.spirv);
    auto t8 = clock::now();
    times["8 spirv-val of the legalized module alone"].push_back(ms(t7, t8));
    times["1 front end (glslang)"].push_back(ms(t0, t1));
    times["2 legalize + validate"].push_back(ms(t1, t2));
    times["3 optimize + validate (incl. step 2 again)"].push_back(ms(t2, t3));
    times["4 SPIRV-Cross GLSL 450"].push_back(ms(t3, t4));
    times["5 SPIRV-Cross GLSL ES 310"].push_back(ms(t4, t5));
    times["6 SPIRV-Cross MSL"].push_back(ms(t5, t6));
    times["7 reflect"].push_back(ms(t6, t7));
    if (r == 0)
      std::cout << "SPIR-V words: front end " << compiled.spirv.size() << ", legalized " << legal.spirv.size()
                << ", optimized " << full.spirv.size() << "\n";
  }
  for (auto& [step, values] : times) {
    std::sort(values.begin(), values.end());
    std::cout << step << ": median " << values[values.size() / 2] << " ms\n";
  }
}
