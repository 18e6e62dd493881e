// SPDX-License-Identifier: Apache-2.0
#include "lint/pack_view.hpp"

namespace kiln {

PackView read_pack_view(const PackReader& pack) {
  const Manifest& manifest = pack.manifest();
  PackView view;
  for (const ManifestBinary& binary : manifest.binaries) view.binaries.push_back({std::string(stage_name(binary.stage))});
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
