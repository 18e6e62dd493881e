#include "lint/pack_view.hpp"

namespace kiln {

PackView read_pack_view(const PackReader& pack) {
  const Manifest& manifest = pack.manifest();
  auto interface = [](const std::vector<StageVariable>& variables) {
    std::vector<PackView::InterfaceVariable> out;
    for (const StageVariable& v : variables) out.push_back({static_cast<int>(v.location), v.name, v.type});
    return out;
  };
  PackView view;
  for (const ManifestBinary& binary : manifest.binaries) {
    const Reflection& reflection = manifest.reflections[binary.reflection];  // in range: the reader checked
    view.binaries.push_back({std::string(stage_name(binary.stage)), interface(reflection.inputs), interface(reflection.outputs)});
  }
  for (const ManifestPass& pass : manifest.passes) {
    PackView::Pass& p = view.passes.emplace_back();
    p.name = pass.name;
    for (const ManifestVariant& variant : pass.variants) {
      PackView::Variant& v = p.variants.emplace_back();
      v.keywords = variant.keywords;
      for (const auto& [stage, binary] : variant.binaries) v.binaries[std::string(stage_name(stage))] = binary;
    }
  }
  return view;
}

}  // namespace kiln
