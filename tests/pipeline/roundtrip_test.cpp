// SPDX-License-Identifier: Apache-2.0
// Differential test: every shader of tests/pipeline/roundtrip/ is compiled twice, directly by glslang
// (its own preprocessor on the original text, no kiln preprocessing) and by a kiln build, and the
// optimized SPIR-V must be the same bytes. kiln compiles the text glslang's preprocessor printed, and
// that text must carry every token exactly (character literals, 1.#INF, string escapes, macros).
#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <mutex>

#include "kiln/build.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "optimize/spirv_tools.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

const std::filesystem::path kCorpus = std::filesystem::path(KILN_SOURCE_DIR) / "tests/pipeline/roundtrip";

// glslang on the original file, with the options kiln's front end documents (HLSL, Vulkan 1.1, SPIR-V 1.3,
// 16-bit types), the keywords as `#define K 1` as kiln defines them, then kiln's back end.
std::vector<uint32_t> compile_directly(const std::string& text, const std::string& name, EShLanguage stage,
                                       const std::string& entry, const std::vector<std::string>& keywords,
                                       std::string& log) {
  static std::once_flag once;
  std::call_once(once, [] { glslang::InitializeProcess(); });
  const auto messages = static_cast<EShMessages>(EShMsgReadHlsl | EShMsgSpvRules | EShMsgVulkanRules |
                                                 EShMsgHlslEnable16BitTypes);
  glslang::TShader shader(stage);
  const char* source = text.c_str();
  const char* names = name.c_str();
  shader.setStringsWithLengthsAndNames(&source, nullptr, &names, 1);
  std::string preamble;
  for (const std::string& k : keywords) preamble += "#define " + k + " 1\n";
  shader.setPreamble(preamble.c_str());
  shader.setEntryPoint(entry.c_str());
  shader.setEnvInput(glslang::EShSourceHlsl, stage, glslang::EShClientVulkan, 100);
  shader.setEnvClient(glslang::EShClientVulkan, glslang::EShTargetVulkan_1_1);
  shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_3);
  if (!shader.parse(GetDefaultResources(), 100, false, messages)) {
    log = shader.getInfoLog();
    return {};
  }
  glslang::TProgram program;
  program.addShader(&shader);
  if (!program.link(messages)) {
    log = program.getInfoLog();
    return {};
  }
  glslang::SpvOptions options;
  options.disableOptimizer = true;
  options.validate = false;
  std::vector<uint32_t> spirv;
  glslang::GlslangToSpv(*program.getIntermediate(stage), spirv, &options);
  SpirvResult optimized = legalize_validate_optimize(std::move(spirv), true);
  if (!optimized) {
    for (const std::string& m : optimized.error().messages) log += m + "\n";
    return {};
  }
  return optimized->spirv;
}

// One corpus file as a one-pass pack: its build errors, or nothing.
std::string build_one(const testing::TempDir& dir, const std::filesystem::path& file, BuildReport& report) {
  const std::string name = file.stem().string();
  dir.write(file.filename().string(), testing::read_file(file));
  dir.write(name + ".pack.json", R"({"name": ")" + name + R"(", "targets": ["spirv"], "passes": [{"name": "P", "source": ")" +
                                     file.filename().string() + R"(", "stages": {"vertex": "V", "fragment": "F"}}]})");
  BuildOptions options;
  options.pack_file = dir / (name + ".pack.json");
  options.output_dir = dir / name;
  options.worker_executable = KILN_WORKER_PATH;
  DiagnosticSink sink;
  report = build_pack(options, sink);
  std::string errors;
  for (const Diagnostic& d : sink.diagnostics()) errors += format_diagnostic(d);
  return errors;
}

std::string disassembled(std::string_view bytes) {
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), words.size() * 4);
  return disassemble_spirv(words);
}

TEST(RoundTrip, EveryCorpusShaderCompilesThroughKilnToTheSpirvGlslangGivesItDirectly) {
  testing::TempDir dir;
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(kCorpus))
    if (entry.path().extension() == ".hlsl") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  ASSERT_GE(files.size(), 5u);
  size_t compared = 0;
  for (const auto& file : files) {
    BuildReport report;
    const std::string errors = build_one(dir, file, report);
    if (!report.ok) {
      ADD_FAILURE() << file.filename() << " does not build through kiln:\n" << errors;
      continue;
    }
    PackReader pack = PackReader::open(report.manifest, PackReader::Check::Full);
    const std::string text = testing::read_file(file);
    for (size_t v = 0; v < pack.variant_count("P"); ++v) {
      SelectedVariant variant = pack.variant("P", v);
      for (const StageView& stage : variant.stages) {
        std::string log;
        std::vector<uint32_t> direct =
            compile_directly(text, file.filename().string(), stage.stage == "vertex" ? EShLangVertex : EShLangFragment,
                             stage.entry_point, variant.keywords, log);
        ASSERT_FALSE(direct.empty()) << file.filename() << " " << stage.stage << ": " << log;
        const std::string_view direct_bytes(reinterpret_cast<const char*>(direct.data()), direct.size() * 4);
        EXPECT_TRUE(stage.spirv == direct_bytes)
            << file.filename() << " " << stage.stage << " " << ::testing::PrintToString(variant.keywords)
            << ": kiln's SPIR-V differs from glslang's\nkiln:\n" << disassembled(stage.spirv) << "\nglslang:\n"
            << disassemble_spirv(direct);
        ++compared;
      }
    }
  }
  EXPECT_GE(compared, 2 * files.size());
}

}  // namespace
}  // namespace kiln
