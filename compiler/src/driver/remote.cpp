#include "driver/remote.hpp"

#include <map>

#include "driver/outputs.hpp"
#include "driver/stage_timer.hpp"
#include "pack/pack_writer.hpp"

namespace kiln {

RemoteKey remote_pack_key(const RemoteCache& remote, const BuildSettings& settings, const Plan& plan,
                          const BuildOptions& options) {
  RemoteKeyHasher key;
  remote.start_key(key, "pack");
  add_build_inputs(key, settings, plan, options);
  return key.add(plan.pack.name).finish();
}

bool fetch_remote_pack(RemoteCache& remote, const RemoteKey& key, const BuildOptions& options, const Plan& plan,
                       const std::string& inputs_hash, DiagnosticSink& sink) {
  std::optional<std::string> archive_file = remote.fetch_pack(key, options.output_dir, plan.pack.name);
  if (!archive_file) return false;
  remove_orphaned_archives(options.output_dir, plan.pack.name, *archive_file);
  if (Result<void> stamped = write_stamp(options.output_dir, plan.pack.name, *archive_file, inputs_hash); !stamped)
    sink.report(DiagId::OutputUnwritable, SourceLocation{options.output_dir.string(), 0, 0}, stamped.error().message);
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

void upload_to_remote(RemoteCache& remote, const CompileResults& results, const std::vector<Binary>& binaries,
                      BuildReport& report) {
  StageTimer timer(report, "remote upload");
  std::vector<RemoteCache::ModuleUpload> uploads;
  std::map<Hash128, size_t> upload_of;
  for (const CompiledModule& m : results.modules)
    if (m.output && m.remote_key) {
      upload_of.emplace(m.key, uploads.size());
      uploads.push_back({*m.remote_key, m.output.get()});
    }
  std::vector<RemoteCache::AliasUpload> aliases;
  for (size_t b = 0; b < binaries.size(); ++b) {
    auto module = results.module_of[b] ? upload_of.find(*results.module_of[b]) : upload_of.end();
    if (results.front_end_ran[b] && binaries[b].output && results.remote_key_of[b] && module != upload_of.end())
      aliases.push_back({*results.remote_key_of[b], module->second, *results.module_of[b], &results.front_messages[b]});
  }
  remote.upload(uploads, aliases);
}

void report_remote(RemoteCache& remote, DiagnosticSink& sink, BuildReport& report) {
  remote.report_problems(sink);
  report.remote = remote.report();
}

}  // namespace kiln
