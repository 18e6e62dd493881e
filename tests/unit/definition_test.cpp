// Pack definitions and scene profiles: the fields kiln accepts are the fields the JSON schemas in
// variants/schema/ describe, so that an editor validating with the schema and kiln agree.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "definition/definition.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

using nlohmann::json;

json read_schema(const char* name) {
  return json::parse(testing::read_file(std::filesystem::path(KILN_SOURCE_DIR) / "variants/schema" / name));
}

// The properties an object schema lists, sorted; and that it refuses any other.
std::vector<std::string> listed(const json& object_schema) {
  EXPECT_EQ(object_schema.value("additionalProperties", json(true)), json(false))
      << "the schema must refuse unknown fields, as kiln does: " << object_schema.dump().substr(0, 120);
  std::vector<std::string> names;
  for (auto& [name, value] : object_schema.at("properties").items()) names.push_back(name);
  return names;
}

std::vector<std::string> sorted(const std::vector<std::string_view>& fields) {
  std::vector<std::string> names(fields.begin(), fields.end());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(Definition, SchemasListExactlyTheFieldsKilnAccepts) {
  const DefinitionFields& kiln = definition_fields();
  const json pack = read_schema("pack.schema.json");
  EXPECT_EQ(listed(pack), sorted(kiln.pack));
  EXPECT_EQ(listed(pack.at("properties").at("passes").at("items")), sorted(kiln.pass));
  EXPECT_EQ(listed(pack.at("properties").at("constraints").at("items")), sorted(kiln.constraint));
  EXPECT_EQ(listed(pack.at("properties").at("materials").at("items")), sorted(kiln.material));
  EXPECT_EQ(listed(read_schema("scene.schema.json")), sorted(kiln.scene));
}

TEST(Definition, BundledPackDefinitionsAndSceneProfilesLoadWithoutDiagnostics) {
  const std::filesystem::path variants = std::filesystem::path(KILN_SOURCE_DIR) / "variants";
  size_t packs = 0, scenes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(variants)) {
    if (!entry.path().string().ends_with(".pack.json")) continue;
    DiagnosticSink sink;
    EXPECT_TRUE(load_pack_definition(entry.path(), ReadLimits{}, sink)) << entry.path();
    EXPECT_TRUE(sink.diagnostics().empty()) << entry.path();
    ++packs;
  }
  for (const auto& entry : std::filesystem::directory_iterator(variants / "scenes")) {
    if (entry.path().extension() != ".json") continue;
    DiagnosticSink sink;
    EXPECT_TRUE(load_scene_profile(entry.path(), ReadLimits{}, sink)) << entry.path();
    EXPECT_TRUE(sink.diagnostics().empty()) << entry.path();
    ++scenes;
  }
  EXPECT_GE(packs, 2u);
  EXPECT_GE(scenes, 3u);
}

}  // namespace
}  // namespace kiln
