// SPDX-License-Identifier: Apache-2.0
#include "driver/emit.hpp"

#include <nlohmann/json.hpp>

#include "common/files.hpp"
#include "driver/build_context.hpp"
#include "optimize/spirv_tools.hpp"
#include "common/blob.hpp"
#include "cross/targets.hpp"

namespace kiln {

void emit_dumps(BuildContext& build, const Plan& plan, const StageSources& sources, const std::vector<Binary>& binaries,
                const std::set<std::string>& emit, const std::filesystem::path& output_dir) {
  if (emit.empty()) return;
  StageTimer timer(build, "emit");
  DiagnosticSink& sink = build.sink;
  const std::filesystem::path root = output_dir / "emit";
  auto put = [&](const std::filesystem::path& path, const std::string& bytes) {
    std::error_code ec;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (Result<void> written = write_output_file(path, bytes); !written)
      sink.report(DiagId::OutputUnwritable, SourceLocation{path.string(), 0, 0}, written.error().message);
  };
  if (emit.count("variants")) {
    nlohmann::json listing = nlohmann::json::array();
    for (uint32_t p = 0; p < plan.passes.size(); ++p)
      for (const Variant& v : plan.expansions[p].variants)
        listing.push_back({{"pass", plan.pack.passes[p].name}, {"keywords", enabled_keywords(plan.passes[p].groups, v)}});
    put(root / "variants.json", listing.dump(2) + "\n");
  }
  for (const StageSource& s : sources.list) {
    const std::filesystem::path base =
        root / plan.pack.passes[s.pass].name / std::string(stage_name(s.stage)) / keywords_slug(s.defines);
    if (emit.count("preprocessed") && s.preprocessed && s.ok) put(base.string() + ".hlsl", s.text);
    if (s.binary < 0 || !binaries[static_cast<size_t>(s.binary)].output) continue;  // did not compile
    const JobOutput& out = *binaries[static_cast<size_t>(s.binary)].output;
    if (emit.count("spvasm")) put(base.string() + ".spvasm", disassemble_spirv(unpack_spirv(out.blobs.at(Target::Spirv))));
    for (const TargetName& target : kTargetNames)
      if (target.cross_compiled && emit.count(std::string(target.emit)) && out.blobs.count(target.target))
        put(base.string() + std::string(target.extension), unpack_blob(out.blobs.at(target.target)));
    if (emit.count("reflection")) put(base.string() + ".reflection.json", nlohmann::json(out.reflection).dump(2) + "\n");
  }
}

}  // namespace kiln
