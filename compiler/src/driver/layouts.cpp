#include "driver/layouts.hpp"

#include <set>

#include "driver/stage_timer.hpp"
#include "reflect/reflect.hpp"

namespace kiln {

std::optional<std::vector<nlohmann::json>> check_pass_layouts(const Plan& plan, const StageSources& sources,
                                                              const std::vector<Binary>& binaries, DiagnosticSink& sink,
                                                              BuildReport& report) {
  StageTimer timer(report, "reflect");
  const int errors_before = sink.error_count();
  std::vector<nlohmann::json> layouts(plan.passes.size());
  for (uint32_t p = 0; p < plan.passes.size(); ++p) {
    std::vector<LayoutSource> layout_sources;
    std::set<int> seen;
    for (const StageSource& s : sources.list) {
      if (s.pass != p || !seen.insert(s.binary).second) continue;
      layout_sources.push_back({variant_description(plan, s), &binaries[static_cast<size_t>(s.binary)].output->reflection});
    }
    layouts[p] = merge_pass_layout(plan.pack.passes[p].name, layout_sources, plan.pack.passes[p].defined_at, sink);
  }
  if (sink.error_count() != errors_before) return std::nullopt;
  return layouts;
}

}  // namespace kiln
