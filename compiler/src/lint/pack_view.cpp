#include "lint/pack_view.hpp"

namespace kiln {

using nlohmann::json;

PackView read_pack_view(const PackReader& pack) {
  const json& manifest = pack.manifest();
  auto interface = [](const json& variables) {
    std::vector<PackView::InterfaceVariable> out;
    for (const json& v : variables) out.push_back({v.at("location").get<int>(), v.at("name").get<std::string>(), v.at("type").get<std::string>()});
    return out;
  };
  PackView view;
  try {
    const json& reflections = manifest.at("reflections");
    for (const json& binary : manifest.at("binaries")) {
      const json& reflection = reflections.at(binary.at("reflection").get<size_t>());
      view.binaries.push_back({binary.at("stage").get<std::string>(),
                               interface(reflection.value("inputs", json::array())),
                               interface(reflection.value("outputs", json::array()))});
    }
    for (const json& pass : manifest.at("passes")) {
      PackView::Pass& p = view.passes.emplace_back();
      p.name = pass.at("name").get<std::string>();
      for (const json& variant : pass.at("variants"))
        p.variants.push_back({variant.at("keywords").get<std::vector<std::string>>(),
                              variant.at("binaries").get<std::map<std::string, size_t>>()});
    }
  } catch (const json::exception& e) {
    throw PackError(PackError::Code::Format, std::string("the manifest lacks what lint reads: ") + e.what());
  }
  return view;
}

}  // namespace kiln
