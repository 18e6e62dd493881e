// SPDX-License-Identifier: Apache-2.0
// Kiln's optimizer recipe (optimize/spirv_tools.cpp: -O without the passes whose work kiln's legalization has
// already done) against SPIRV-Tools' -O, on every distinct module of the bundled library's default pack and of
// the real-world-HLSL corpus (tests/corpus, with the option each header documents). The modules are planned,
// preprocessed and compiled by the front end as a build does (in the compiler workers), legalized once by the
// core recipe, then optimized both ways in this process: the two must be the same words once IDs are compacted.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <string_view>

#include <nlohmann/json.hpp>

#include "common/parallel.hpp"
#include "driver/plan.hpp"
#include "driver/settings.hpp"
#include "driver/stage_sources.hpp"
#include "kiln/build.hpp"
#include "kiln/pack_reader.hpp"
#include "kiln/manifest_json.hpp"
#include "optimize/spirv_tools.hpp"
#include "test_support.hpp"
#include "workers/worker_pool.hpp"

namespace kiln {
namespace {

using Module = std::vector<uint32_t>;

// Every distinct front-end module of the pack's build (front ends run in two compiler workers); with `every` N > 1,
// those of every N-th distinct stage source only (in the plan's order).
std::vector<Module> front_end_modules(const std::filesystem::path& pack_file, size_t every = 1) {
  BuildOptions options;
  options.pack_file = pack_file;
  options.jobs = 2;
  options.worker_executable = KILN_WORKER_PATH;
  DiagnosticSink sink;
  BuildContext build(sink);
  auto plan = make_plan(options, build);
  auto settings = plan ? choose_settings(options, *plan, sink) : std::nullopt;
  EXPECT_TRUE(settings) << pack_file;
  if (!settings) return {};
  WorkerPool workers(KILN_WORKER_PATH, 2, WorkerLimits{});
  Preprocessor preprocessor(*plan, *settings, workers, build, WorkerLimits{});
  StageSources sources = prepare_stage_sources(build, *plan, *settings, nullptr, preprocessor);
  std::vector<CompileJob> jobs;
  std::set<std::tuple<Stage, std::string, std::string>> seen;  // (stage, entry point, text): one front end each
  for (const StageSource& source : sources.list) {
    EXPECT_TRUE(source.ok && source.preprocessed) << pack_file;
    const std::string& entry = plan->pack.passes[source.pass].entry_points[static_cast<size_t>(source.stage)];
    if (!seen.insert({source.stage, entry, source.text}).second || (seen.size() - 1) % every != 0) continue;
    CompileJob job;
    job.id = jobs.size();
    job.kind = JobKind::FrontEnd;
    job.stage = source.stage;
    job.entry_point = entry;
    job.source_name = "source";
    job.source = source.text;
    job.targets = settings->targets;
    job.bindings = plan->pack.passes[source.pass].bindings_for(source.stage);
    jobs.push_back(std::move(job));
  }
  std::set<Module> modules;
  workers.run(jobs, [&](size_t index, WorkerOutcome outcome) {
    EXPECT_TRUE(outcome.kind == WorkerOutcome::Kind::Done && outcome.output.ok) << pack_file << " job " << index;
    modules.insert(std::move(outcome.output.spirv));
  });
  return {modules.begin(), modules.end()};
}

struct Comparison {
  size_t modules = 0;
  size_t fit = 0;  // kiln's recipe applied (the others got -O: the comparison says nothing about them)
  size_t identical_after_compaction = 0;
  size_t identical_bytes = 0;
  std::string first_difference;  // which module, and its two disassemblies' sizes
};

Comparison compare_recipes(const std::vector<Module>& front_ends) {
  std::vector<int> same(front_ends.size()), same_bytes(front_ends.size()), fit(front_ends.size());
  std::vector<std::string> why(front_ends.size());
  parallel_for(front_ends.size(), 2, [&](size_t i) {
    const SpirvResult legal = legalize_spirv_core(front_ends[i]);
    if (!legal || !validate_spirv(legal->spirv)) {
      why[i] = "the core recipe does not legalize it (a build uses the full recipe, then -O)";
      same[i] = same_bytes[i] = 1;
      return;
    }
    fit[i] = fits_kiln_recipe(legal->spirv);
    const SpirvResult stock_result = optimize_spirv(legal->spirv, OptimizerRecipe::Stock);
    const SpirvResult kiln_result = optimize_spirv(legal->spirv, OptimizerRecipe::Kiln);
    const bool both = stock_result && kiln_result;
    const SpirvModule stock = stock_result ? *stock_result : SpirvModule{}, kiln = kiln_result ? *kiln_result : SpirvModule{};
    same_bytes[i] = both && stock.spirv == kiln.spirv;
    same[i] = same_bytes[i] || (both && compact_ids(stock.spirv) == compact_ids(kiln.spirv));
    if (!same[i])
      why[i] = "-O: " + std::to_string(stock.spirv.size()) + " words, kiln's recipe: " + std::to_string(kiln.spirv.size()) +
               " words\n-O:\n" + disassemble_spirv(compact_ids(stock.spirv)).substr(0, 4000) + "\nkiln's recipe:\n" +
               disassemble_spirv(compact_ids(kiln.spirv)).substr(0, 4000);
  });
  Comparison c;
  c.modules = front_ends.size();
  for (size_t i = 0; i < front_ends.size(); ++i) {
    c.identical_after_compaction += same[i];
    c.identical_bytes += same_bytes[i];
    c.fit += fit[i];
    if (!same[i] && c.first_difference.empty()) c.first_difference = "module " + std::to_string(i) + ": " + why[i];
  }
  return c;
}

// The suite compares every fourth distinct source of the default pack (about 300 modules, 1 in 4 of each stage's
// keyword combinations in the plan's order) and the whole corpus; the full label (KILN_TEST_FULL=1, ctest --preset
// full) compares every module: 124 s on this 2-core machine against the sample's 18 s.
TEST(OptimizerRecipe, KilnsRecipeGivesMinusOsModulesForTheDefaultPackAndTheCorpus) {
  const std::filesystem::path root(KILN_SOURCE_DIR);
  const char* full = std::getenv("KILN_TEST_FULL");
  const bool every_module = full && std::string_view(full) == "1";
  std::vector<Module> library = front_end_modules(root / "variants/lit.pack.json", every_module ? 1 : 4);
  // The bundled library's default pack: 1,303 distinct modules when this test was written.
  EXPECT_GE(library.size(), every_module ? 1000u : 250u);

  testing::TempDir dir;
  std::vector<Module> corpus;
  for (const auto& entry : std::filesystem::directory_iterator(root / "tests/corpus")) {
    if (entry.path().extension() != ".hlsl") continue;
    // The header (see corpus_test.cpp): "// stages: vertex=A fragment=B", "// option: {bindings}".
    std::istringstream lines(testing::read_file(entry.path()));
    nlohmann::json stages = nlohmann::json::object(), pass{{"name", "P"}, {"source", entry.path().string()}};
    nlohmann::json pack{{"name", "corpus"}};
    for (std::string line; std::getline(lines, line) && line.starts_with("// ");) {
      if (line.starts_with("// stages: ")) stages = testing::corpus_stages(line.substr(11), entry.path().parent_path());
      if (line.starts_with("// option: ")) pack["bindings"] = nlohmann::json::parse(line.substr(11));
    }
    pass["stages"] = stages;
    pack["passes"] = nlohmann::json::array({pass});
    for (Module& m : front_end_modules(dir.write(entry.path().stem().string() + ".pack.json", pack.dump())))
      corpus.push_back(std::move(m));
  }
  EXPECT_GE(corpus.size(), 60u);  // 33 shaders, most of two stages

  for (const auto& [name, modules] : {std::pair{"default pack", &library}, std::pair{"corpus", &corpus}}) {
    const Comparison c = compare_recipes(*modules);
    std::cout << "[ recipe   ] " << name << ": kiln's recipe applies to " << c.fit << " of " << c.modules << " modules; "
              << c.identical_after_compaction << " identical to -O's after ID compaction (" << c.identical_bytes
              << " byte for byte)\n";
    EXPECT_EQ(c.identical_after_compaction, c.modules) << name << ": " << c.first_difference;
    // Every module of both sets is one kiln's recipe applies to: otherwise it got -O and proved nothing.
    EXPECT_EQ(c.fit, c.modules) << name;
  }
}

// The recipe is named where a pack's provenance is: the stock recipe is -O's passes exactly, kiln's a strict
// subsequence of them (it leaves passes out, never adds or reorders).
TEST(OptimizerRecipe, KilnsRecipeIsMinusOWithPassesLeftOutInTheSameOrder) {
  const std::vector<std::string> stock = optimizer_pass_names(OptimizerRecipe::Stock);
  const std::vector<std::string> kiln = optimizer_pass_names(OptimizerRecipe::Kiln);
  ASSERT_EQ(stock.size(), 44u) << "SPIRV-Tools' -O changed: check kiln's recipe against it (docs/design.md)";
  EXPECT_LT(kiln.size(), stock.size());
  size_t at = 0;
  for (const std::string& pass : kiln) {
    while (at < stock.size() && stock[at] != pass) ++at;
    ASSERT_LT(at, stock.size()) << pass << " is not in -O at this point";
    ++at;
  }
}

// --optimize=O keeps -O available: the manifest names the recipe that made the pack, the recipe is in the
// inputs hash (and every cache key: a cache filled by one recipe does not serve the other), and the SPIR-V is
// the same once IDs are compacted.
TEST(OptimizerRecipe, ManifestNamesTheRecipeAndTheRecipeIsPartOfTheInputs) {
  testing::TempDir dir;
  const std::filesystem::path shader = std::filesystem::path(KILN_SOURCE_DIR) / "tests/corpus/engine_no_registers.hlsl";
  dir.write("p.pack.json", nlohmann::json{{"name", "p"},
                                          {"passes", {{{"name", "P"}, {"source", shader.string()},
                                                       {"stages", {{"vertex", "vert"}, {"fragment", "frag"}}}}}}}
                               .dump());
  nlohmann::json manifests[2];
  std::vector<std::string> spirv[2];
  for (OptimizerRecipe recipe : {OptimizerRecipe::Kiln, OptimizerRecipe::Stock}) {
    const int i = recipe == OptimizerRecipe::Stock;
    const std::string name(optimizer_recipe_name(recipe));
    BuildOptions options;
    options.pack_file = dir / "p.pack.json";
    options.output_dir = dir / name;
    options.cache_dir = dir / "cache";  // shared: the second build must not take the first one's modules
    options.jobs = 2;
    options.worker_executable = KILN_WORKER_PATH;
    options.optimizer_recipe = recipe;
    DiagnosticSink sink;
    const BuildReport report = build_pack(options, sink);
    ASSERT_TRUE(report.ok) << (sink.diagnostics().empty() ? "" : format_diagnostic(sink.diagnostics()[0]));
    EXPECT_EQ(report.cache_hits, 0u) << name;
    manifests[i] = nlohmann::json::parse(testing::read_file(dir / name / "p.manifest.json"));
    PackReader pack = PackReader::open(dir / name);
    for (const StageView& stage : pack.select("P", {}).stages) spirv[i].emplace_back(stage.spirv);
  }
  EXPECT_EQ(manifests[0]["options"]["optimizer_recipe"], "kiln");
  EXPECT_EQ(manifests[1]["options"]["optimizer_recipe"], "O");
  EXPECT_NE(manifests[0]["inputs_hash"], manifests[1]["inputs_hash"]);
  ASSERT_EQ(spirv[0].size(), 2u);
  ASSERT_EQ(spirv[1].size(), 2u);
  for (size_t s = 0; s < 2; ++s) {
    auto words = [](const std::string& bytes) {
      Module m(bytes.size() / 4);
      std::memcpy(m.data(), bytes.data(), m.size() * 4);
      return compact_ids(m);
    };
    EXPECT_EQ(words(spirv[0][s]), words(spirv[1][s])) << "stage " << s;
  }
}

}  // namespace
}  // namespace kiln
