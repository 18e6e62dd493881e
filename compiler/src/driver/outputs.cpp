// SPDX-License-Identifier: Apache-2.0
#include "driver/outputs.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include "common/files.hpp"
#include "kiln/pack_format.hpp"
#include "pack/pack_writer.hpp"

namespace kiln {
namespace {

std::string depfile_escape(const std::string& path) {
  std::string out;
  for (char c : path) {
    if (c == ' ' || c == '#') out += '\\';
    if (c == '$') out += '$';
    out += c;
  }
  return out;
}

std::string file_signature(const std::filesystem::path& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return "missing";
  return std::to_string(info.st_size) + ":" + std::to_string(info.st_mtim.tv_sec) + "." + std::to_string(info.st_mtim.tv_nsec);
}

std::filesystem::path stamp_path(const std::filesystem::path& directory, const std::string& name) {
  return directory / (name + ".stamp");
}

std::string stamp_text(const std::filesystem::path& directory, const std::string& name, const std::string& archive_file,
                       const std::string& inputs_hash) {
  return inputs_hash + "\n" + file_signature(manifest_path(directory, name)) + "\n" + archive_file + "\n" +
         file_signature(directory / archive_file) + "\n";
}

}  // namespace

bool prepare_output_directory(const std::filesystem::path& directory, DiagnosticSink& sink) {
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (!ec && ::access(directory.c_str(), W_OK) == 0) return true;
  sink.report(DiagId::OutputUnwritable, SourceLocation{directory.string(), 0, 0},
              "output directory '" + directory.string() + "' is not writable" + (ec ? ": " + ec.message() : std::string()));
  return false;
}

std::optional<std::string> current_archive(const std::filesystem::path& directory, const std::string& name,
                                           const std::string& inputs_hash) {
  auto stamp = read_binary_file(stamp_path(directory, name));
  if (!stamp) return std::nullopt;
  const size_t first = stamp->find('\n'), second = first == std::string::npos ? first : stamp->find('\n', first + 1),
               third = second == std::string::npos ? second : stamp->find('\n', second + 1);
  if (third == std::string::npos) return std::nullopt;
  std::string archive_file = stamp->substr(second + 1, third - second - 1);
  if (!is_archive_file_name(archive_file, name) || *stamp != stamp_text(directory, name, archive_file, inputs_hash))
    return std::nullopt;
  return archive_file;
}

Result<void> write_stamp(const std::filesystem::path& directory, const std::string& name, const std::string& archive_file,
                        const std::string& inputs_hash) {
  return write_output_file(stamp_path(directory, name), stamp_text(directory, name, archive_file, inputs_hash));
}

bool write_depfile(const std::filesystem::path& depfile, const std::filesystem::path& manifest,
                   const std::vector<std::filesystem::path>& dependencies, DiagnosticSink& sink) {
  std::string text = depfile_escape(manifest.string()) + ":";
  for (const auto& dependency : dependencies) text += " \\\n  " + depfile_escape(dependency.string());
  Result<void> written = write_output_file(depfile, text + "\n");
  if (written) return true;
  sink.report(DiagId::OutputUnwritable, SourceLocation{depfile.string(), 0, 0}, written.error().message);
  return false;
}

}  // namespace kiln
