// SPDX-License-Identifier: Apache-2.0
// Loads the pack built at build time and selects variants the way a renderer would.
#include <kiln/pack_reader.hpp>

#include <iostream>

int main() {
  try {
    kiln::PackReader pack = kiln::PackReader::open(PACK_DIR);
    std::cout << "pack " << pack.name() << ": " << pack.variant_count("Forward") << " Forward variants\n";
    // Variants the bundled mobile scene requests.
    for (std::vector<std::string> keywords : std::vector<std::vector<std::string>>{
             {"_MOBILE_BRDF", "_HALF_PRECISION"},
             {"_MAIN_LIGHT_SHADOWS", "_MOBILE_BRDF", "_HALF_PRECISION", "FOG_EXP"},
             {"_ADDITIONAL_LIGHTS_VERTEX", "_MOBILE_BRDF", "_HALF_PRECISION", "UNRELATED_GLOBAL_KEYWORD"}}) {
      kiln::SelectedVariant v = pack.select("Forward", keywords);
      const kiln::StageView* fragment = v.stage("fragment");
      if (!fragment || fragment->spirv.size() < 20 || fragment->glsl.empty() || fragment->msl.empty()) {
        std::cerr << "variant without outputs\n";
        return 1;
      }
      std::cout << "selected Forward variant " << v.index << " (" << fragment->spirv.size() << " bytes of SPIR-V)\n";
    }
    // Cascaded shadows are not in the mobile scene: stripped, and the reader says so.
    try {
      pack.select("Forward", {"_MAIN_LIGHT_SHADOWS_CASCADE", "_MOBILE_BRDF", "_HALF_PRECISION"});
      std::cerr << "a stripped variant was selected\n";
      return 1;
    } catch (const kiln::PackError& e) {
      if (e.code() != kiln::PackError::Code::Stripped) throw;
      std::cout << "stripped as expected: " << e.what() << "\n";
    }
    std::cout << "consumer ok\n";
    return 0;
  } catch (const kiln::PackError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
