// interface-mismatch: a fragment input the stage before it (vertex, domain or geometry) does not write, or writes
// with another type.
#include <algorithm>
#include <set>

#include "lint/rules/rules.hpp"

namespace kiln::rules {
namespace {

void check_interface_mismatch(const LintContext& context, LintReport& report) {
  const PackView& pack = *context.pack;
  std::set<std::pair<size_t, size_t>> checked;
  for (const PackView::Pass& pass : pack.passes) {
    const SourceLocation at = context.pass_location(pass.name);
    for (const PackView::Variant& variant : pass.variants) {
      // The fragment stage reads what the last stage before it writes: geometry, else domain, else vertex (the
      // hull and domain stages' own interfaces are per control point, arrayed, and not compared here).
      auto fragment = variant.binaries.find("fragment");
      auto vertex = variant.binaries.end();
      std::string producer;
      for (const char* stage : {"geometry", "domain", "vertex"})
        if (vertex = variant.binaries.find(stage); vertex != variant.binaries.end()) {
          producer = stage;
          break;
        }
      if (vertex == variant.binaries.end() || fragment == variant.binaries.end()) continue;
      if (!checked.insert({vertex->second, fragment->second}).second) continue;
      const auto& outputs = pack.binaries.at(vertex->second).outputs;
      const auto& inputs = pack.binaries.at(fragment->second).inputs;
      const std::string keywords = join_keywords(variant.keywords);
      for (const PackView::InterfaceVariable& input : inputs) {
        auto written = std::find_if(outputs.begin(), outputs.end(), [&](const auto& o) { return o.location == input.location; });
        if (written == outputs.end())
          add_finding(report, RuleId::InterfaceMismatch, at,
                      "pass '" + pass.name + "' [" + keywords + "]: fragment input '" + input.name + "' at location " +
                          std::to_string(input.location) + " is not written by the " + producer + " stage");
        else if (written->type != input.type)
          add_finding(report, RuleId::InterfaceMismatch, at,
                      "pass '" + pass.name + "' [" + keywords + "]: location " + std::to_string(input.location) + " is " +
                          written->type + " in the " + producer + " stage and " + input.type + " in the fragment stage");
      }
    }
  }
}

}  // namespace

constinit const LintRule interface_mismatch{
    RuleId::InterfaceMismatch, "InterfaceMismatch",
    "A fragment input is not written by the vertex stage, or with another type.",
    "For every distinct pair of vertex and fragment binaries a pass's variants use, each fragment input location "
    "must be a vertex output of the same type (from the reflection of both stages). A mismatch reads undefined "
    "values on the GPU. Reported at the pass's definition in the pack file.",
    Severity::Error, LintInput::BuiltPack, check_interface_mismatch};

}  // namespace kiln::rules
