// SPDX-License-Identifier: Apache-2.0
#include "driver/layouts.hpp"

#include <map>

#include "common/files.hpp"
#include "driver/build_context.hpp"
#include "layouts/interface_check.hpp"
#include "layouts/layout_check.hpp"

namespace kiln {
namespace {

// What the layout check (layouts/) needs of a pass: each distinct binary with its stage, reflection and the
// variants that use it, and a way to find a resource's declaration.
PassLayoutInput layout_input(const Plan& plan, const SourceLocator& locator, uint32_t pass, const StageSources& sources,
                             const std::vector<Binary>& binaries) {
  PassLayoutInput input;
  input.pass = plan.pack.passes[pass].name;
  input.pass_location = plan.pack.passes[pass].defined_at;
  std::map<int, size_t> index_of_binary;
  const auto& variant_source = sources.variant_source[pass];
  for (size_t v = 0; v < variant_source.size(); ++v) {
    input.variant_names.push_back(join_keywords(enabled_keywords(plan.passes[pass].groups, plan.expansions[pass].variants[v])));
    for (int source : variant_source[v]) {
      if (source < 0) continue;
      const int b = sources.list[static_cast<size_t>(source)].binary;
      auto [it, inserted] = index_of_binary.emplace(b, input.binaries.size());
      if (inserted) {
        const Stage stage = binaries[static_cast<size_t>(b)].stage;
        input.binaries.push_back({stage, &binaries[static_cast<size_t>(b)].output->reflection, {}});
        input.combined_image_samplers = input.combined_image_samplers || plan.pack.passes[pass].bindings_for(stage).combines();
      }
      input.binaries[it->second].variants.push_back(v);
    }
  }
  const std::string entry_name = display_path(plan.declarations[pass].entry);
  input.locate = [&locator, pass, entry_name](const std::string& name) { return locator.declaration(pass, name, entry_name); };
  input.locate_stage_variable = [&locator, &plan, pass, entry_name](const std::string& name, Stage stage) {
    return locator.declaration(pass, name, entry_name, plan.declarations[pass].stage_entry[static_cast<size_t>(stage)]);
  };
  return input;
}

}  // namespace

std::optional<std::vector<PassLayout>> check_pass_layouts(BuildContext& build, const Plan& plan,
                                                              const SourceLocator& locator, const StageSources& sources,
                                                              const std::vector<Binary>& binaries) {
  StageTimer timer(build, "reflect");
  DiagnosticSink& sink = build.sink;
  const int errors_before = sink.error_count();
  std::vector<PassLayout> layouts(plan.passes.size());
  for (uint32_t p = 0; p < plan.passes.size(); ++p) {
    const PassLayoutInput input = layout_input(plan, locator, p, sources, binaries);
    if (std::optional<PassLayout> layout = check_pass_layout(input, sink)) layouts[p] = std::move(*layout);
    check_stage_interfaces(input, sink);
  }
  if (sink.error_count() != errors_before) return std::nullopt;
  return layouts;
}

}  // namespace kiln
