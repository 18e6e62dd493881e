// SPDX-License-Identifier: Apache-2.0
#include "layouts/interface_check.hpp"

#include <algorithm>
#include <map>
#include <set>

namespace kiln {
namespace {

// The stage whose outputs the fragment stage reads: geometry, else domain, else vertex. The hull and domain
// stages' own interfaces are per control point (arrayed) and are not compared here.
constexpr std::array kProducers{Stage::Geometry, Stage::Domain, Stage::Vertex};

std::string variants_text(const std::vector<std::string>& names, const std::vector<size_t>& variants) {
  const std::string first = names[variants.front()];
  if (variants.size() == 1) return "variant [" + first + "]";
  return std::to_string(variants.size()) + " variants, the first [" + first + "]";
}

// glslang names a struct-returned output by its member ("@entryPointOutput.uv"): the member is the user's name.
std::string user_name(const std::string& name) {
  const std::string prefix = "@entryPointOutput.";
  return name.starts_with(prefix) ? name.substr(prefix.size()) : name;
}

// Where a stage's sources declare a variable the reflection names: glslang names a struct member of an input
// "i.uv" or "@entryPointOutput.uv"; the source declares "uv".
SourceLocation declaration_of(const PassLayoutInput& input, const std::string& reflected, Stage stage) {
  if (!input.locate_stage_variable || reflected.empty()) return {};
  const size_t dot = reflected.rfind('.');
  return input.locate_stage_variable(dot == std::string::npos ? reflected : reflected.substr(dot + 1), stage);
}

}  // namespace

bool check_stage_interfaces(const PassLayoutInput& input, DiagnosticSink& sink) {
  // (producer binary, fragment binary) -> the variants that use the pair.
  std::map<std::pair<size_t, size_t>, std::vector<size_t>> pairs;
  for (size_t v = 0; v < input.variant_names.size(); ++v) {
    auto binary_of = [&](Stage stage) -> std::optional<size_t> {
      for (size_t i = 0; i < input.binaries.size(); ++i)
        if (input.binaries[i].stage == stage && std::binary_search(input.binaries[i].variants.begin(), input.binaries[i].variants.end(), v))
          return i;
      return std::nullopt;
    };
    const std::optional<size_t> fragment = binary_of(Stage::Fragment);
    if (!fragment) continue;
    for (Stage producer : kProducers)
      if (const std::optional<size_t> from = binary_of(producer)) {
        pairs[{*from, *fragment}].push_back(v);
        break;
      }
  }
  // One report per distinct mismatch, with every variant it is in (a keyword that changes another stage's code
  // makes more pairs of binaries, not more mismatches), at the fragment input's declaration in the HLSL; for a type
  // mismatch, a note at the output's.
  struct Finding {
    std::string text, note, input, output;
    Stage producer = Stage::Vertex;
    std::vector<size_t> variants;
  };
  std::vector<Finding> findings;
  auto add = [&](Finding found, const std::vector<size_t>& variants) {
    auto it = std::find_if(findings.begin(), findings.end(), [&](const Finding& f) { return f.text == found.text; });
    if (it == findings.end()) it = findings.insert(findings.end(), std::move(found));
    it->variants.insert(it->variants.end(), variants.begin(), variants.end());
  };
  for (const auto& [pair, variants] : pairs) {
    const auto& producer = input.binaries[pair.first];
    const std::string producer_name(stage_name(producer.stage));
    const std::vector<StageVariable>& outputs = producer.reflection->outputs;
    for (const StageVariable& in : input.binaries[pair.second].reflection->inputs) {
      auto written = std::find_if(outputs.begin(), outputs.end(), [&](const StageVariable& out) { return out.location == in.location; });
      if (written == outputs.end())
        add({"fragment input '" + in.name + "' (location " + std::to_string(in.location) + ") is not written by the " +
                 producer_name + " stage",
             "Vulkan needs every fragment input location written by the stage before it: write it, or remove the input",
             in.name, "", producer.stage, {}},
            variants);
      else if (written->type != in.type)
        add({"location " + std::to_string(in.location) + " is " + written->type + " ('" + user_name(written->name) + "') in the " +
                 producer_name + " stage and " + in.type + " ('" + in.name + "') in the fragment stage",
             "Vulkan needs an output and the input at its location to have the same type", in.name, user_name(written->name),
             producer.stage, {}},
            variants);
    }
  }
  for (Finding& finding : findings) {
    std::sort(finding.variants.begin(), finding.variants.end());
    SourceLocation at = declaration_of(input, finding.input, Stage::Fragment);
    if (at.line == 0) at = input.pass_location;
    sink.report(DiagId::InterfaceMismatch, at,
                "pass '" + input.pass + "', " + variants_text(input.variant_names, finding.variants) + ": " + finding.text,
                {finding.note});
    if (!finding.output.empty())
      if (SourceLocation out = declaration_of(input, finding.output, finding.producer); out.line > 0)
        sink.report(Diagnostic{DiagId::InterfaceMismatch, Severity::Note, out,
                               "'" + finding.output + "' is the " + std::string(stage_name(finding.producer)) +
                                   " stage's output declared here",
                               {}});
  }
  return findings.empty();
}

}  // namespace kiln
