// SPDX-License-Identifier: Apache-2.0
#include "driver/remote.hpp"

#include "driver/outputs.hpp"
#include "pack/pack_writer.hpp"

namespace kiln {

RemoteKey remote_pack_key(const RemoteCache& remote, const BuildSettings& settings, const Plan& plan) {
  RemoteKeyHasher key;
  remote.start_key(key, "pack");
  add_build_inputs(key, settings, plan);
  return key.add(plan.pack.name).finish();
}

bool fetch_remote_pack(RemoteCache& remote, const RemoteKey& key, const std::filesystem::path& output_dir,
                       const Plan& plan, const std::string& inputs_hash, DiagnosticSink& sink) {
  std::optional<std::string> archive_file = remote.fetch_pack(key, output_dir, plan.pack.name);
  if (!archive_file) return false;
  remove_orphaned_archives(output_dir, plan.pack.name, *archive_file);
  if (Result<void> stamped = write_stamp(output_dir, plan.pack.name, *archive_file, inputs_hash); !stamped)
    sink.report(DiagId::OutputUnwritable, SourceLocation{output_dir.string(), 0, 0}, stamped.error().message);
  return true;
}

RemoteKey remote_source_key(const RemoteCache& remote, const BuildSettings& settings, const PassDefinition& pass,
                            Stage stage, std::string_view text) {
  RemoteKeyHasher key;
  remote.start_key(key, "source");
  return settings.add_compile_options(key, pass, stage).add(text).finish();
}

RemoteKey remote_module_key(const RemoteCache& remote, const BuildSettings& settings, const PassDefinition& pass,
                            Stage stage, const std::vector<uint32_t>& spirv) {
  RemoteKeyHasher key;
  remote.start_key(key, "module");
  return settings.add_compile_options(key, pass, stage)
      .add(std::string_view(reinterpret_cast<const char*>(spirv.data()), spirv.size() * 4))
      .finish();
}

}  // namespace kiln
