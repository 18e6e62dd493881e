// SPDX-License-Identifier: Apache-2.0
// kiln test's harness on the default pack golden.setup builds: the shards of one N split the Forward variants
// into whole pipelines (every variant in exactly one shard, the variants of one pipeline together), and a
// variant rendered again reuses its pipeline or program and gives the same bits.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <set>

#include "golden/golden.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "render/backend.hpp"

namespace kiln::render {
namespace {

const std::filesystem::path kWork = KILN_GOLDEN_WORK;
const std::filesystem::path kScene = std::filesystem::path(KILN_SOURCE_DIR) / "variants/scenes/render/spheres.json";

TEST(Shards, EveryForwardVariantRunsInExactlyOneShardWithTheOtherVariantsOfItsPipeline) {
  PackReader pack = PackReader::open(kWork / "packs/lit");
  const size_t count = pack.variant_count("Forward");
  for (Api api : {Api::Vulkan, Api::Gl, Api::Gles}) {
    for (unsigned shards : {1u, 2u, 3u, 32u}) {
      std::map<size_t, unsigned> shard_of;
      std::map<std::pair<const char*, const char*>, unsigned> pipeline_shard;
      for (unsigned shard = 0; shard < shards; ++shard) {
        for (size_t i : variants_to_run(pack, api, shard, shards)) {
          EXPECT_TRUE(shard_of.emplace(i, shard).second) << "variant " << i << " runs twice (" << api_name(api) << ")";
          SelectedVariant v = pack.variant("Forward", i);
          auto text = [&](const char* stage) {
            const StageView* s = v.stage(stage);
            return (api == Api::Vulkan ? s->spirv : api == Api::Gl ? s->glsl : s->gles).data();
          };
          auto [it, inserted] = pipeline_shard.emplace(std::pair{text("vertex"), text("fragment")}, shard);
          EXPECT_EQ(it->second, shard) << "variant " << i << " shares its pipeline with another shard's";
        }
      }
      EXPECT_EQ(shard_of.size(), count) << api_name(api) << ", " << shards << " shards";
    }
  }
}

class Pipelines : public testing::TestWithParam<Api> {};

TEST_P(Pipelines, AVariantRenderedAgainReusesItsPipelineAndGivesTheSameBits) {
  PackReader pack = PackReader::open(kWork / "packs/lit");
  auto backend = Backend::open(GetParam(), pack, load_scene(kScene), 64, 64);
  SelectedVariant variant = pack.select("Forward", {"_MAIN_LIGHT_SHADOWS", "_ADDITIONAL_LIGHTS"});
  Image first = backend->render(variant);
  Image again = backend->render(variant);
  EXPECT_EQ(backend->pipelines_created(), 1u);
  EXPECT_EQ(backend->pipelines_reused(), 1u);
  EXPECT_EQ(first.rgba, again.rgba);
  backend->render(pack.select("Forward", {}));
  EXPECT_EQ(backend->pipelines_created(), 2u);
}

INSTANTIATE_TEST_SUITE_P(EveryApi, Pipelines, testing::Values(Api::Vulkan, Api::Gl, Api::Gles),
                         [](const testing::TestParamInfo<Api>& param) { return api_name(param.param); });

}  // namespace
}  // namespace kiln::render
