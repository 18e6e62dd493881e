// SPDX-License-Identifier: Apache-2.0
#include "common/files.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

namespace kiln {
namespace {

// Offset of the first invalid UTF-8 sequence, or npos.
size_t first_invalid_utf8(std::string_view text) {
  size_t i = 0;
  while (i < text.size()) {
    unsigned char c = static_cast<unsigned char>(text[i]);
    size_t length = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
    if (length == 0 || i + length > text.size()) return i;
    for (size_t k = 1; k < length; ++k)
      if ((static_cast<unsigned char>(text[i + k]) >> 6) != 0x2) return i;
    i += length;
  }
  return std::string_view::npos;
}

}  // namespace

std::string display_path(const std::filesystem::path& path) {
  std::error_code ec;
  std::filesystem::path absolute = std::filesystem::absolute(path, ec).lexically_normal();
  auto cwd = std::filesystem::current_path(ec);
  if (!ec) {
    auto relative = absolute.lexically_relative(cwd);
    if (!relative.empty() && *relative.begin() != "..") return relative.string();
  }
  return path.string();
}

SourceLocation locate_json_string(const std::string& path, std::string_view text, std::string_view value) {
  std::string quoted = "\"" + std::string(value) + "\"";
  size_t at = text.find(quoted);
  if (at == std::string_view::npos) return SourceLocation{path, 0, 0};
  return location_of_offset(path, text, at + 1);
}

std::optional<std::string> read_text_file(const std::filesystem::path& path, const ReadLimits& limits,
                                          DiagnosticSink& sink, const SourceLocation& referenced_from) {
  const std::string shown = display_path(path);
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) {
    sink.report(DiagId::FileUnreadable, referenced_from, "cannot open '" + shown + "': " + std::strerror(errno));
    return std::nullopt;
  }
  if (!S_ISREG(info.st_mode)) {
    const char* kind = S_ISDIR(info.st_mode)    ? "a directory"
                       : S_ISFIFO(info.st_mode) ? "a FIFO"
                       : S_ISCHR(info.st_mode)  ? "a character device"
                       : S_ISBLK(info.st_mode)  ? "a block device"
                       : S_ISSOCK(info.st_mode) ? "a socket"
                                                : "a special file";
    sink.report(DiagId::FileNotRegular, referenced_from, "'" + shown + "' is " + kind + ", not a regular file");
    return std::nullopt;
  }
  if (static_cast<uint64_t>(info.st_size) > limits.max_file_bytes) {
    sink.report(DiagId::FileTooLarge, referenced_from,
                "'" + shown + "' is " + std::to_string(info.st_size) + " bytes, over the limit of " +
                    std::to_string(limits.max_file_bytes) + " bytes");
    return std::nullopt;
  }
  // O_NONBLOCK: if the file was swapped for a FIFO after stat, open still returns at once.
  int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    sink.report(DiagId::FileUnreadable, referenced_from, "cannot open '" + shown + "': " + std::strerror(errno));
    return std::nullopt;
  }
  std::string text;
  char buffer[1 << 16];
  for (;;) {
    ssize_t got = ::read(fd, buffer, sizeof buffer);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      ::close(fd);
      sink.report(DiagId::FileUnreadable, referenced_from, "cannot read '" + shown + "': " + std::strerror(errno));
      return std::nullopt;
    }
    if (got == 0) break;
    text.append(buffer, static_cast<size_t>(got));
    if (text.size() > limits.max_file_bytes) break;
  }
  ::close(fd);
  if (text.size() > limits.max_file_bytes) {
    sink.report(DiagId::FileTooLarge, referenced_from,
                "'" + shown + "' is over the limit of " + std::to_string(limits.max_file_bytes) + " bytes");
    return std::nullopt;
  }
  if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);
  if (size_t nul = text.find('\0'); nul != std::string::npos) {
    sink.report(DiagId::FileNotText, location_of_offset(shown, text, nul),
                "file contains a NUL byte; is '" + shown + "' a binary file?");
    return std::nullopt;
  }
  if (size_t bad = first_invalid_utf8(text); bad != std::string_view::npos) {
    sink.report(DiagId::FileNotText, location_of_offset(shown, text, bad),
                "file is not valid UTF-8 text (byte 0x" +
                    [&] {
                      char hex[8];
                      std::snprintf(hex, sizeof hex, "%02X", static_cast<unsigned char>(text[bad]));
                      return std::string(hex);
                    }() +
                    ")");
    return std::nullopt;
  }
  // Only files read here may be quoted by diagnostics: they passed the confinement and size rules.
  auto quotable = std::make_shared<const std::string>(text);
  sink.add_source(path.string(), quotable);
  if (shown != path.string()) sink.add_source(shown, quotable);
  return text;
}

std::optional<std::string> read_binary_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return std::move(buffer).str();
}

std::filesystem::path make_scratch_directory(const std::filesystem::path& directory, std::string_view prefix) {
  std::error_code ec;
  for (std::filesystem::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!name.starts_with(prefix)) continue;
    const std::string rest = name.substr(prefix.size());
    const size_t dash = rest.find('-');
    if (dash == 0 || dash == std::string::npos || dash > 10 || rest.find_first_not_of("0123456789") != dash) continue;
    const long long pid = std::stoll(rest.substr(0, dash));
    // Alive, or not ours to judge (EPERM: another user's live process), is left alone.
    if (pid > 0 && pid <= INT32_MAX && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH)) continue;
    if (it->is_directory(ec) && !it->is_symlink(ec)) {
      std::error_code ignored;
      std::filesystem::remove_all(it->path(), ignored);
    }
  }
  std::string scratch = (directory / (std::string(prefix) + std::to_string(::getpid()) + "-XXXXXX")).string();
  if (!::mkdtemp(scratch.data())) return {};
  return scratch;
}

}  // namespace kiln
