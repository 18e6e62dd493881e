// SPDX-License-Identifier: Apache-2.0
// The compatibility corpus (tests/corpus/*.hlsl): small shaders written in the styles real projects use.
// Each file states in its header comment what kiln does with it (slang-style test modes):
//   // default: ok | K1406          the result with default options
//   // option: {...}                 one documented "bindings" object (docs/bindings.md) that it needs or shows
//   // layout: name kind set.binding, ...   the pass layout with the option (or the defaults)
//   // stages: vertex=Entry fragment=Entry      or vertex=pairs/A.vert.hlsl:main ... (a file per stage)
//   // targets: spirv msl              the pack's targets, when not all four (what SPIRV-Cross cannot write)
// Every build validates the SPIR-V and cross-compiles to every target the pack names (all four by default).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "kiln/build.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

using nlohmann::json;

struct CorpusShader {
  std::filesystem::path file;
  std::string text;
  std::map<std::string, std::string> header;  // "default", "option", "layout", "stages"
};

std::vector<CorpusShader> corpus() {
  std::vector<CorpusShader> shaders;
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(KILN_SOURCE_DIR) / "tests/corpus")) {
    if (entry.path().extension() != ".hlsl") continue;
    CorpusShader shader{entry.path(), testing::read_file(entry.path()), {}};
    std::istringstream lines(shader.text);
    for (std::string line; std::getline(lines, line) && line.starts_with("// ");) {
      const size_t colon = line.find(": ");
      if (colon != std::string::npos) shader.header[line.substr(3, colon - 3)] = line.substr(colon + 2);
    }
    shaders.push_back(std::move(shader));
  }
  std::sort(shaders.begin(), shaders.end(), [](const auto& a, const auto& b) { return a.file < b.file; });
  return shaders;
}

std::string layout_of(const std::filesystem::path& manifest) {
  json m = json::parse(testing::read_file(manifest));
  std::string out;
  for (const json& r : m["passes"][0]["layout"]["resources"])
    out += (out.empty() ? "" : ", ") + r["name"].get<std::string>() + " " + r["kind"].get<std::string>() + " " +
           r["set"].dump() + "." + r["binding"].dump();
  return out;
}

using testing::errors_of;

// Builds the shader into a one-pass pack with `bindings` (a JSON object, or empty).
bool build(const testing::TempDir& dir, const CorpusShader& shader, const std::string& bindings, const std::string& out,
           DiagnosticSink& sink) {
  json stages = testing::corpus_stages(shader.header.at("stages"), shader.file.parent_path());
  json pack{{"name", "corpus"}, {"passes", {{{"name", "P"}, {"source", shader.file.string()}, {"stages", stages}}}}};
  if (!bindings.empty()) pack["bindings"] = json::parse(bindings);
  if (shader.header.count("targets")) {
    std::istringstream names(shader.header.at("targets"));
    pack["targets"] = json::array();
    for (std::string name; names >> name;) pack["targets"].push_back(name);
  }
  dir.write(out + ".pack.json", pack.dump());
  BuildOptions options;
  options.pack_file = dir / (out + ".pack.json");
  options.output_dir = dir / out;
  options.jobs = 2;
  options.worker_executable = KILN_WORKER_PATH;
  return build_pack(options, sink).ok;
}

TEST(Corpus, EveryShaderBuildsAsItsHeaderSaysWithTheDocumentedOptions) {
  const std::vector<CorpusShader> shaders = corpus();
  ASSERT_GE(shaders.size(), 16u);
  size_t with_defaults = 0, with_one_option = 0;
  for (const CorpusShader& shader : shaders) {
    SCOPED_TRACE(shader.file.filename().string());
    ASSERT_TRUE(shader.header.count("default") && shader.header.count("layout") && shader.header.count("stages"));
    testing::TempDir dir;
    DiagnosticSink plain;
    const bool default_ok = build(dir, shader, "", "default", plain);
    if (shader.header.at("default") == "ok") {
      EXPECT_TRUE(default_ok) << errors_of(plain);
    } else {
      EXPECT_FALSE(default_ok);
      EXPECT_TRUE(plain.contains(DiagId::LayoutMismatch)) << errors_of(plain);
    }
    with_defaults += default_ok;
    std::string out = "default";
    if (shader.header.count("option")) {
      DiagnosticSink optioned;
      const bool ok = build(dir, shader, shader.header.at("option"), "option", optioned);
      EXPECT_TRUE(ok) << errors_of(optioned);
      with_one_option += ok;
      out = "option";
    } else {
      with_one_option += default_ok;
    }
    if (::testing::Test::HasFailure()) continue;
    EXPECT_EQ(layout_of(dir / out / "corpus.manifest.json"), shader.header.at("layout"));
    // Validated (a build fails otherwise) and cross-compiled: every stage has every target.
    PackReader pack = PackReader::open(dir / out, PackReader::Check::Full);
    const std::string targets = shader.header.count("targets") ? " " + shader.header.at("targets") + " " : " spirv glsl gles msl ";
    const auto wanted = [&](const char* name) { return targets.find(" " + std::string(name) + " ") != std::string::npos; };
    for (const StageView& stage : pack.select("P", {}).stages) {
      EXPECT_FALSE(stage.spirv.empty());
      EXPECT_EQ(stage.glsl.empty(), !wanted("glsl"));
      EXPECT_EQ(stage.gles.empty(), !wanted("gles"));
      EXPECT_EQ(stage.msl.empty(), !wanted("msl"));
    }
  }
  std::cout << "[ corpus   ] " << shaders.size() << " shaders: " << with_defaults << " build with default options, "
            << with_one_option << " with default options or one documented option\n";
  EXPECT_EQ(with_one_option, shaders.size());
}

}  // namespace
}  // namespace kiln
