// SPDX-License-Identifier: Apache-2.0
// kiln inspect: a built pack's passes, layouts and variants; --extract writes its blobs as files.
#include <iostream>

#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "kiln/files.hpp"
#include "kiln/manifest_json.hpp"
#include "kiln/pack_reader.hpp"

namespace kiln::cli {
namespace {

using nlohmann::json;

int run_inspect(const std::string& pack_dir, bool as_json, const std::string& extract) {
  try {
    kiln::PackReader pack = kiln::PackReader::open(pack_dir, kiln::PackReader::Check::Full);
    const kiln::Manifest& manifest = pack.manifest();
    if (!extract.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(extract, ec);
      if (ec || !std::filesystem::is_directory(extract)) {
        std::cerr << extract << ": error[K1601]: cannot create the --extract directory"
                  << (ec ? ": " + ec.message() : std::string(": a file of that name is in the way")) << "\n";
        return kiln::exit_status(kiln::ExitClass::Environment);
      }
      for (size_t b = 0; b < manifest.binaries.size(); ++b) {
        const kiln::ManifestBinary& binary = manifest.binaries[b];
        for (const auto& [target, id] : binary.blobs) {
          std::string name = "binary" + std::to_string(b) + "." + std::string(kiln::stage_name(binary.stage)) +
                             std::string(kiln::target_extension(target));
          if (kiln::Result<void> written = kiln::write_output_file(std::filesystem::path(extract) / name, std::string(pack.blob(id)));
              !written) {
            std::cerr << extract << ": error[K1601]: " << written.error().message << "\n";
            return kiln::exit_status(kiln::ExitClass::Environment);
          }
        }
      }
    }
    if (as_json) {
      json out{{"name", pack.name()}, {"archive", manifest.archive.file}, {"tools", manifest.tools}, {"passes", json::array()}};
      for (const kiln::ManifestPass& pass : manifest.passes) {
        json variants = json::array();
        for (const kiln::ManifestVariant& variant : pass.variants) variants.push_back(variant.keywords);
        json entry{{"name", pass.name}, {"variants", variants}, {"layout", pass.layout}};
        // The bindings chosen (docs/bindings.md): the options, defines and resulting layout of the pass.
        if (!pass.bindings.empty()) entry["bindings"] = pass.bindings;
        if (!pass.defines.empty()) entry["defines"] = pass.defines;
        out["passes"].push_back(std::move(entry));
      }
      std::cout << out.dump(2) << "\n";
    } else {
      std::cout << "pack '" << pack.name() << "', format " << manifest.format_version << ", " << manifest.binaries.size()
                << " binaries, " << manifest.archive.blobs << " blobs, " << manifest.archive.size << " bytes in "
                << manifest.archive.file << "\n";
      for (const kiln::ManifestPass& pass : manifest.passes) {
        std::cout << "  pass " << pass.name << ": " << pass.variants.size() << " variants\n";
        if (!pass.bindings.empty()) std::cout << "    bindings: " << pass.bindings << "\n";
        if (!pass.defines.empty()) std::cout << "    defines: " << json(pass.defines).dump() << "\n";
        for (const kiln::Resource& r : pass.layout.resources)
          std::cout << "    set " << r.set << " binding " << r.binding << ": " << r.name << " ("
                    << kiln::resource_kind_name(r.kind) << ")\n";
        for (const kiln::ManifestVariant& variant : pass.variants)
          std::cout << "    [" << kiln::join_keywords(variant.keywords) << "]\n";
      }
    }
    return 0;
  } catch (const kiln::PackError& error) {
    std::cerr << (error.file().empty() ? pack_dir : error.file()) << ": error: " << error.what() << "\n";
    return 1;
  }
}

class InspectVerb final : public Verb {
 public:
  CLI::App* add_to(CLI::App& app) override {
    CLI::App* verb = app.add_subcommand("inspect", "Show a built pack; optionally extract its blobs");
    verb->add_option("pack_dir", pack_dir_, "Directory holding a pack (or its manifest)")->required();
    verb->add_flag("--json", as_json_, "Print JSON");
    verb->add_option("--extract", extract_, "Write each blob as a file (.spv, .glsl, .es.glsl, .metal)");
    return verb;
  }
  int run() override { return run_inspect(pack_dir_, as_json_, extract_); }

 private:
  std::string pack_dir_, extract_;
  bool as_json_ = false;
};

}  // namespace

std::unique_ptr<Verb> make_inspect_verb() { return std::make_unique<InspectVerb>(); }

}  // namespace kiln::cli
