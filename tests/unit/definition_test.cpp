// SPDX-License-Identifier: Apache-2.0
// Pack definitions and scene profiles: the fields kiln accepts are the fields the JSON schemas in
// variants/schema/ describe, so that an editor validating with the schema and kiln agree.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "definition/definition.hpp"
#include "frontend/bindings.hpp"
#include "kiln/command_line.hpp"
#include "kiln/lint_rule_id.hpp"
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

// The schema's target names are kiln/targets.def's, in its order, for the pack and for a pass.
TEST(Definition, SchemaTargetsAreTheTargetTable) {
  std::vector<std::string> table;
  for (const TargetName& target : kTargetNames) table.emplace_back(target.name);
  const json pack = read_schema("pack.schema.json");
  EXPECT_EQ(pack.at("properties").at("targets").at("items").at("enum").get<std::vector<std::string>>(), table);
  EXPECT_EQ(pack.at("properties").at("passes").at("items").at("properties").at("targets").at("items").at("enum")
                .get<std::vector<std::string>>(),
            table);
}

TEST(Definition, SchemasListExactlyTheFieldsKilnAccepts) {
  const DefinitionFields& kiln = definition_fields();
  const json pack = read_schema("pack.schema.json");
  EXPECT_EQ(listed(pack), sorted(kiln.pack));
  EXPECT_EQ(listed(pack.at("properties").at("passes").at("items")), sorted(kiln.pass));
  EXPECT_EQ(listed(pack.at("properties").at("constraints").at("items")), sorted(kiln.constraint));
  EXPECT_EQ(listed(pack.at("properties").at("materials").at("items")), sorted(kiln.material));
  EXPECT_EQ(listed(read_schema("scene.schema.json")), sorted(kiln.scene));
  EXPECT_EQ(listed(pack.at("$defs").at("bindings")), sorted(kiln.bindings));
  EXPECT_EQ(listed(pack.at("$defs").at("bindings").at("properties").at("shifts").at("items")), sorted(kiln.shift));
  EXPECT_EQ(listed(pack.at("properties").at("lint")), sorted(kiln.lint));
  EXPECT_EQ(listed(pack.at("$defs").at("stage").at("oneOf").at(1)), sorted(kiln.stage));
}

// The schema's lint rules are kiln/lint_rules.def's, in its order: an editor completes and checks "disable".
TEST(Definition, SchemaLintRulesAreTheRuleTable) {
  const std::vector<std::string> table(kRuleIdTexts.begin(), kRuleIdTexts.end());
  const json pack = read_schema("pack.schema.json");
  EXPECT_EQ(pack.at("properties").at("lint").at("properties").at("disable").at("items").at("enum").get<std::vector<std::string>>(),
            table);
}

// [[vk::binding]] is found by the declared name, through other attributes, template arguments and array sizes.
TEST(Definition, VkBindingAttributesAreFoundByTheDeclaredName) {
  const auto found = find_vk_bindings(
      "[[vk::binding(3, 2)]] cbuffer PerFrame : register(b0) { float4 a; };\n"
      "[[ vk :: binding ( 5 ) ]] [[vk::image_format(\"rgba8\")]] RWTexture2D<float4> output[4] : register(u1);\n"
      "[[vk::binding(7, 1)]] ConstantBuffer<Light> lights;\n"
      "[[vk::location(0)]] float4 notAResource;\n"
      "float4 myvk::binding(1)]] x;\n");
  EXPECT_EQ(found, (std::map<std::string, std::pair<uint32_t, uint32_t>>{
                       {"PerFrame", {3, 2}}, {"output", {5, 0}}, {"lights", {7, 1}}}));
}

TEST(Definition, DefinesParseAsTheCommandLineWritesThem) {
  EXPECT_EQ(parse_define("FAST"), (Define{"FAST", "1"}));
  EXPECT_EQ(parse_define("LEVEL=3"), (Define{"LEVEL", "3"}));
  EXPECT_EQ(parse_define("EMPTY="), (Define{"EMPTY", ""}));
  EXPECT_EQ(parse_define("EXPR=a=b"), (Define{"EXPR", "a=b"}));
  EXPECT_FALSE(parse_define("2FAST"));
  EXPECT_FALSE(parse_define("A-B=1"));
  EXPECT_FALSE(parse_define("=1"));
  EXPECT_FALSE(parse_define("A=1\n#define B 2"));
}

// -D V=<120,000 characters> reached glslang, whose preprocessor reads names and numbers of up to 1023 characters,
// and came back as a bare "name too long". It is refused first, saying which define, with the value cut to 64 bytes.
TEST(Definition, ADefineTooLongForThePreprocessorIsRefusedWithItsTextCutShort) {
  EXPECT_TRUE(parse_define("V=" + std::string(1023, 'x')));
  EXPECT_TRUE(parse_define("V=" + std::string(1023, 'x') + " + " + std::string(1023, 'y')));
  EXPECT_FALSE(parse_define("V=" + std::string(1024, 'x')));
  EXPECT_FALSE(parse_define(std::string(1024, 'N')));
  DiagnosticSink sink;
  EXPECT_FALSE(parse_command_line_defines({"V=" + std::string(120000, 'x'), std::string(2000, 'N') + "=1"}, sink));
  const std::vector<Diagnostic> diagnostics = sink.diagnostics();
  ASSERT_EQ(diagnostics.size(), 2u);
  EXPECT_EQ(diagnostics[0].message, "-D 'V=" + std::string(62, 'x') +
                                        "... (120002 bytes)': the value of 'V' holds a name or number longer than the 1023 "
                                        "characters the preprocessor reads (expected -D NAME or -D NAME=VALUE)");
  EXPECT_EQ(diagnostics[1].message, "-D '" + std::string(64, 'N') + "... (2002 bytes)': '" + std::string(64, 'N') +
                                        "... (2000 bytes)' is longer than the 1023 characters a preprocessor name may have "
                                        "(expected -D NAME or -D NAME=VALUE)");
}

TEST(Definition, BindingOptionsOverrideFieldByFieldAndASpaceShiftWinsOverAll) {
  BindingOptions pack, pass;
  pack.shifts[{RegisterClass::T, kAllSpaces}] = 16;
  pack.combined_image_samplers = true;
  pass.shifts[{RegisterClass::T, 1}] = 4;
  pass.auto_bind = false;
  pack.override_with(pass);
  EXPECT_EQ(pack.shift(RegisterClass::T, 0), 16u);
  EXPECT_EQ(pack.shift(RegisterClass::T, 1), 4u);
  EXPECT_EQ(pack.shift(RegisterClass::S, 0), 0u);
  EXPECT_EQ(pack.canonical(), "-fvk-t-shift 16 all -fvk-t-shift 4 1 -no-auto-bind -combined-image-samplers");
  EXPECT_EQ(BindingOptions{}.canonical(), "");
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
