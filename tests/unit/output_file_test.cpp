// SPDX-License-Identifier: Apache-2.0
// kiln::write_output_file (kiln/output_file.hpp), the one way kiln writes what it was told to write: a regular file
// is replaced atomically, a device or a FIFO is written in place and stays what it was, a link is never written
// through or replaced unless it leads to a device, a FIFO or a redirected descriptor.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "kiln/output_file.hpp"
#include "test_support.hpp"

namespace kiln {
namespace {

// A character device of the memory driver (1,3 null; 1,7 full) in `dir`, so that a kiln that replaced devices
// would replace the test's, not the machine's; a user who may not make devices gets the machine's own.
std::filesystem::path memory_device(const testing::TempDir& dir, const char* name, unsigned minor) {
  const std::filesystem::path at = dir / name;
  if (::mknod(at.c_str(), S_IFCHR | 0666, makedev(1, minor)) == 0) return at;
  return std::filesystem::path("/dev") / name;
}

mode_t kind_at(const std::filesystem::path& path) {
  struct stat info {};
  return ::lstat(path.c_str(), &info) == 0 ? (info.st_mode & S_IFMT) : 0;
}

TEST(OutputFile, ACharacterDeviceIsWrittenInPlaceAndStaysADevice) {
  testing::TempDir dir;
  const std::filesystem::path null = memory_device(dir, "null", 3);
  Result<void> written = write_output_file(null, "module bytes");
  ASSERT_TRUE(written) << written.error().message;
  EXPECT_EQ(kind_at(null), S_IFCHR);
  for (const auto& entry : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
}

TEST(OutputFile, ADeviceThatTakesNoBytesIsAnErrorNotASuccess) {
  testing::TempDir dir;
  const std::filesystem::path full = memory_device(dir, "full", 7);
  Result<void> written = write_output_file(full, "module bytes");
  ASSERT_FALSE(written);
  EXPECT_NE(written.error().message.find(full.string()), std::string::npos) << written.error().message;
  EXPECT_NE(written.error().message.find("No space left"), std::string::npos) << written.error().message;
  EXPECT_EQ(kind_at(full), S_IFCHR);
}

// The reader end is open (non-blocking) before the write, so the bytes wait in the pipe and nothing waits on time.
TEST(OutputFile, AFifoIsWrittenInPlaceForItsReader) {
  testing::TempDir dir;
  const std::filesystem::path fifo = dir / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(reader, 0);
  Result<void> written = write_output_file(fifo, std::vector<std::string_view>{"two ", "parts"});
  ASSERT_TRUE(written) << written.error().message;
  char buffer[64] = {};
  const ssize_t got = ::read(reader, buffer, sizeof buffer);
  ::close(reader);
  EXPECT_EQ(std::string(buffer, got > 0 ? static_cast<size_t>(got) : 0), "two parts");
  EXPECT_EQ(kind_at(fifo), S_IFIFO);
}

TEST(OutputFile, ALinkToARegularFileIsRefusedAndNeitherIsChanged) {
  testing::TempDir dir;
  dir.write("real.spv", "old");
  std::filesystem::create_symlink("real.spv", dir / "link.spv");
  Result<void> written = write_output_file(dir / "link.spv", "new");
  ASSERT_FALSE(written);
  EXPECT_NE(written.error().message.find("symbolic link"), std::string::npos) << written.error().message;
  EXPECT_NE(written.error().message.find("real.spv"), std::string::npos) << written.error().message;
  EXPECT_EQ(kind_at(dir / "link.spv"), S_IFLNK);
  EXPECT_EQ(testing::read_file(dir / "real.spv"), "old");
  // A dangling link is refused the same way, and nothing is made where it points.
  std::filesystem::create_symlink("nowhere.spv", dir / "dangling.spv");
  ASSERT_FALSE(write_output_file(dir / "dangling.spv", "new"));
  EXPECT_FALSE(std::filesystem::exists(dir / "nowhere.spv"));
  EXPECT_EQ(kind_at(dir / "dangling.spv"), S_IFLNK);
}

TEST(OutputFile, ALinkToADeviceOrAFifoIsWrittenThrough) {
  testing::TempDir dir;
  const std::filesystem::path fifo = dir / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::filesystem::create_symlink(fifo, dir / "to-fifo");
  const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(reader, 0);
  Result<void> written = write_output_file(dir / "to-fifo", "through");
  ASSERT_TRUE(written) << written.error().message;
  char buffer[64] = {};
  const ssize_t got = ::read(reader, buffer, sizeof buffer);
  ::close(reader);
  EXPECT_EQ(std::string(buffer, got > 0 ? static_cast<size_t>(got) : 0), "through");
  EXPECT_EQ(kind_at(dir / "to-fifo"), S_IFLNK);
}

// `-o /dev/stdout > log`: the descriptor the shell opened is the caller's to write, through a link of /dev/fd or
// /proc/self/fd, and written through the descriptor itself: what the process writes to it afterwards comes after
// (a reopened file would have its own offset, and the next write would overwrite what kiln wrote).
TEST(OutputFile, ARedirectedDescriptorIsWrittenThroughTheDescriptorItself) {
  testing::TempDir dir;
  const int fd = ::open((dir / "log").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::write(fd, "head ", 5), 5);
  Result<void> written = write_output_file("/dev/fd/" + std::to_string(fd), "middle ");
  ASSERT_TRUE(written) << written.error().message;
  ASSERT_EQ(::write(fd, "tail", 4), 4);
  ::close(fd);
  EXPECT_EQ(testing::read_file(dir / "log"), "head middle tail");
}

TEST(OutputFile, ADirectoryIsRefused) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir / "out.spv");
  Result<void> written = write_output_file(dir / "out.spv", "bytes");
  ASSERT_FALSE(written);
  EXPECT_NE(written.error().message.find("a directory"), std::string::npos) << written.error().message;
}

// A reader that opened the old file keeps reading it: the new one arrives by rename, whole.
TEST(OutputFile, ARegularFileIsReplacedAtomically) {
  testing::TempDir dir;
  dir.write("pack.json", "old");
  const int old_reader = ::open((dir / "pack.json").c_str(), O_RDONLY);
  ASSERT_GE(old_reader, 0);
  ASSERT_TRUE(write_output_file(dir / "pack.json", "new contents"));
  char buffer[16] = {};
  const ssize_t got = ::read(old_reader, buffer, sizeof buffer);
  ::close(old_reader);
  EXPECT_EQ(std::string(buffer, got > 0 ? static_cast<size_t>(got) : 0), "old");
  EXPECT_EQ(testing::read_file(dir / "pack.json"), "new contents");
  EXPECT_EQ(kind_at(dir / "pack.json"), S_IFREG);
}

}  // namespace
}  // namespace kiln
