// SPDX-License-Identifier: Apache-2.0
#include "kiln/output_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>

namespace kiln {
namespace {

const char* kind_of(mode_t mode) {
  return S_ISDIR(mode)    ? "a directory"
         : S_ISBLK(mode)  ? "a block device"
         : S_ISSOCK(mode) ? "a socket"
         : S_ISCHR(mode)  ? "a character device"
         : S_ISFIFO(mode) ? "a FIFO"
         : S_ISLNK(mode)  ? "a symbolic link"
                          : "a regular file";
}

std::string errno_text() { return std::strerror(errno); }

// Every part, in batches of up to IOV_MAX (an archive is thousands of blobs); a short write resumes inside its part.
// A device that takes no bytes (/dev/full: ENOSPC) is an error, as is a FIFO whose reader went away (EPIPE).
bool write_parts(int fd, const std::vector<std::string_view>& parts) {
  size_t part = 0, offset = 0;  // the first byte not yet written
  while (part < parts.size()) {
    std::vector<iovec> batch;
    for (size_t p = part; p < parts.size() && batch.size() < IOV_MAX; ++p) {
      const size_t skip = p == part ? offset : 0;
      if (parts[p].size() > skip) batch.push_back({const_cast<char*>(parts[p].data() + skip), parts[p].size() - skip});
    }
    if (batch.empty()) return true;
    const ssize_t put = ::writev(fd, batch.data(), static_cast<int>(batch.size()));
    if (put < 0 && errno == EINTR) continue;
    if (put < 0) return false;
    if (put == 0) {
      errno = EIO;
      return false;
    }
    for (auto left = static_cast<size_t>(put); part < parts.size();) {
      const size_t rest = parts[part].size() - offset;
      if (left < rest) {
        offset += left;
        break;
      }
      left -= rest;
      ++part;
      offset = 0;
    }
  }
  return true;
}

// The descriptor of this process that a link ends in (/dev/stdout -> /proc/self/fd/1, /dev/fd/63 from `>(...)`):
// what the shell redirected there, which is the caller's to write whatever it is. Written through the descriptor
// itself, not reopened, so that its offset moves as the shell's and the process's own writes expect (`> log`
// followed by more output, `>> log`).
std::optional<int> own_descriptor(std::filesystem::path link) {
  const std::string own = "/proc/" + std::to_string(::getpid()) + "/fd";
  for (int hop = 0; hop < 8; ++hop) {
    std::error_code ec;
    const std::filesystem::path parent =
        std::filesystem::canonical(link.has_parent_path() ? link.parent_path() : std::filesystem::path("."), ec);
    if (ec) return std::nullopt;
    const std::string name = link.filename().string();
    if (parent == own && !name.empty() && name.size() < 10 && name.find_first_not_of("0123456789") == std::string::npos)
      return std::stoi(name);
    struct stat info {};
    if (::lstat(link.c_str(), &info) != 0 || !S_ISLNK(info.st_mode)) return std::nullopt;
    std::filesystem::path target = std::filesystem::read_symlink(link, ec);
    if (ec) return std::nullopt;
    link = target.is_absolute() ? target : parent / target;
  }
  return std::nullopt;
}

Result<void> write_in_place(const std::filesystem::path& path, const std::vector<std::string_view>& parts) {
  // No O_CREAT: the path was there a moment ago; if it went away, that is an error, not a new file.
  const int fd = ::open(path.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) return failure("cannot open '" + path.string() + "' for writing: " + errno_text());
  if (!write_parts(fd, parts)) {
    std::string error = "cannot write '" + path.string() + "': " + errno_text();
    ::close(fd);
    return failure(std::move(error));
  }
  if (::close(fd) != 0) return failure("cannot write '" + path.string() + "': " + errno_text());
  return {};
}

Result<void> replace_atomically(const std::filesystem::path& path, const std::vector<std::string_view>& parts) {
  static std::atomic<uint64_t> counter{0};
  std::filesystem::path temp;
  int fd = -1;
  // O_EXCL | O_NOFOLLOW: a file or link planted at the temporary name is never written through; a name left by an
  // earlier process of the same pid is skipped.
  for (int attempt = 0; attempt < 16 && fd < 0; ++attempt) {
    temp = path;
    temp += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
    fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (fd < 0 && errno != EEXIST) break;
  }
  if (fd < 0) return failure("cannot create '" + temp.string() + "': " + errno_text());
  if (!write_parts(fd, parts)) {
    std::string error = "cannot write '" + temp.string() + "': " + errno_text();
    ::close(fd);
    ::unlink(temp.c_str());
    return failure(std::move(error));
  }
  if (::close(fd) != 0) {
    std::string error = "cannot write '" + temp.string() + "': " + errno_text();
    ::unlink(temp.c_str());
    return failure(std::move(error));
  }
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    std::string error = "cannot rename '" + temp.string() + "' to '" + path.string() + "': " + errno_text();
    ::unlink(temp.c_str());
    return failure(std::move(error));
  }
  return {};
}

}  // namespace

Result<void> write_output_file(const std::filesystem::path& path, std::string_view bytes) {
  return write_output_file(path, std::vector<std::string_view>{bytes});
}

Result<void> write_output_file(const std::filesystem::path& path, const std::vector<std::string_view>& parts) {
  struct stat here {};
  if (::lstat(path.c_str(), &here) != 0) {
    if (errno == ENOENT) return replace_atomically(path, parts);
    return failure("cannot write '" + path.string() + "': " + errno_text());
  }
  if (S_ISREG(here.st_mode)) return replace_atomically(path, parts);
  if (S_ISCHR(here.st_mode) || S_ISFIFO(here.st_mode)) return write_in_place(path, parts);
  if (!S_ISLNK(here.st_mode))
    return failure("cannot write '" + path.string() + "': it is " + kind_of(here.st_mode) +
                   "; kiln writes regular files, character devices and FIFOs only");
  if (const std::optional<int> fd = own_descriptor(path)) {
    // What this process buffered for the descriptor goes first.
    if (*fd == STDOUT_FILENO) std::fflush(stdout);
    if (*fd == STDERR_FILENO) std::fflush(stderr);
    if (!write_parts(*fd, parts)) return failure("cannot write '" + path.string() + "': " + errno_text());
    return {};
  }
  struct stat target {};
  const bool resolves = ::stat(path.c_str(), &target) == 0;
  if (resolves && (S_ISCHR(target.st_mode) || S_ISFIFO(target.st_mode))) return write_in_place(path, parts);
  std::error_code ec;
  const std::string to = std::filesystem::read_symlink(path, ec).string();
  return failure("cannot write '" + path.string() + "': it is a symbolic link (to '" + to + "', " +
                 (resolves ? kind_of(target.st_mode) : "which does not exist") +
                 "); kiln neither writes through a link nor replaces one: name the file itself, or remove the link");
}

}  // namespace kiln
