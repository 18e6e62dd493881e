// SPDX-License-Identifier: Apache-2.0
// Test helpers: temporary directories with files, and running the kiln CLI with captured output.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>
#include <xxhash.h>

#include <nlohmann/json.hpp>

#include "kiln/diagnostics.hpp"

#include <cerrno>
#include <cstdio>
#include <chrono>
#include <filesystem>
#include <optional>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

extern char** environ;

namespace kiln::testing {

// Every diagnostic of a sink as kiln prints it: the message of a failed build's assertion.
inline std::string errors_of(const DiagnosticSink& sink) {
  std::string text;
  for (const Diagnostic& d : sink.diagnostics()) text += format_diagnostic(d);
  return text;
}

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

class TempDir {
 public:
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "kiln-test-XXXXXX").string();
    path_ = ::mkdtemp(pattern.data());
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    std::filesystem::path file = path_ / name;
    std::filesystem::create_directories(file.parent_path());
    std::ofstream(file, std::ios::binary) << text;
    return file;
  }

 private:
  std::filesystem::path path_;
};

struct RunResult {
  int exit_code = -1;
  std::string out;
  std::string err;
  double seconds = 0;
};

// Runs `program args...` in `cwd`, capturing stdout and stderr through files (no pipe deadlocks).
inline RunResult run(const std::vector<std::string>& argv, const std::filesystem::path& cwd) {
  RunResult result;
  TempDir capture;
  std::string out_path = (capture / "out").string(), err_path = (capture / "err").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addchdir_np(&actions, cwd.c_str());
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  auto start = std::chrono::steady_clock::now();
  pid_t pid = -1;
  if (posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ) == 0) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  posix_spawn_file_actions_destroy(&actions);
  result.out = read_file(out_path);
  result.err = read_file(err_path);
  return result;
}

inline RunResult run_kiln(std::vector<std::string> args, const std::filesystem::path& cwd) {
  args.insert(args.begin(), KILN_CLI_PATH);
  return run(args, cwd);
}

// Runs `program args...` in `cwd` with stdin, stdout and stderr on a pseudo-terminal of `columns` columns,
// as a user at a terminal runs it, with TERM set to `term` (unset when empty). Output processing is off, so
// the bytes read are the bytes the program wrote; stdout and stderr arrive interleaved in `out`.
inline RunResult run_on_terminal(const std::vector<std::string>& argv, const std::filesystem::path& cwd,
                                 const std::string& term = "xterm", unsigned short columns = 80) {
  RunResult result;
  termios mode{};
  ::cfmakeraw(&mode);
  winsize size{};
  size.ws_col = columns;
  size.ws_row = 24;
  // Everything the child needs is made before the fork: after it, only async-signal-safe calls.
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  std::vector<std::string> variables;
  for (char** v = environ; *v; ++v)
    if (std::string_view(*v).substr(0, 5) != "TERM=") variables.emplace_back(*v);
  if (!term.empty()) variables.push_back("TERM=" + term);
  std::vector<char*> env;
  for (std::string& v : variables) env.push_back(v.data());
  env.push_back(nullptr);
  int master = -1;
  auto start = std::chrono::steady_clock::now();
  pid_t pid = ::forkpty(&master, nullptr, &mode, &size);
  if (pid < 0) return result;
  if (pid == 0) {
    if (::chdir(cwd.c_str()) != 0) ::_exit(126);
    ::execve(args[0], args.data(), env.data());
    ::_exit(127);
  }
  char buffer[4096];
  for (;;) {
    ssize_t n = ::read(master, buffer, sizeof buffer);
    if (n > 0) result.out.append(buffer, static_cast<size_t>(n));
    else if (n < 0 && errno == EINTR) continue;
    else break;  // EIO: the child closed the terminal's last descriptor
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  ::close(master);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

// Files anywhere below `dir` (empty if it does not exist).
inline std::vector<std::filesystem::path> files_below(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> files;
  std::error_code ec;
  if (!std::filesystem::exists(dir, ec)) return files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir, ec))
    if (entry.is_regular_file()) files.push_back(entry.path());
  return files;
}

// A pack manifest that a test edited, with its own checksum made right again, so that the edit reaches the
// reader's checks behind the checksum. Written from the rule in kiln/pack_format.hpp, not with kiln's code:
// "manifest_xxh3_64" holds the XXH3-64 of the file with those 16 hex digits zeroed.
inline std::string resealed_manifest(std::string text) {
  const std::string key = "\"manifest_xxh3_64\": \"";
  const size_t digits = text.find(key) + key.size();
  text.replace(digits, 16, 16, '0');
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(XXH3_64bits(text.data(), text.size())));
  return text.replace(digits, 16, hex);
}

// A pack whose archive a test edited, sealed again by the rules in kiln/pack_format.hpp (not with kiln's code):
// the archive's header checksums and size, its content name, the manifest's record of it and the manifest's own
// checksum are made right, so that the edit reaches the reader's checks behind the checksums. The archive
// replaces the one the manifest named; returns its path.
inline std::filesystem::path reseal_pack(const std::filesystem::path& manifest, std::string archive) {
  auto put64 = [&](size_t at, uint64_t value) {
    for (int i = 0; i < 8; ++i) archive[at + i] = static_cast<char>(value >> (8 * i));
  };
  auto get64 = [&](size_t at) {
    uint64_t value = 0;
    for (int i = 0; i < 8; ++i) value |= static_cast<uint64_t>(static_cast<unsigned char>(archive[at + i])) << (8 * i);
    return value;
  };
  put64(24, archive.size());
  // The head (blob table and runtime index, from byte 64 to the index's end), where the header says it ends.
  const uint64_t head_end = get64(32) + get64(40);
  if (head_end >= 64 && head_end <= archive.size()) put64(48, XXH3_64bits(archive.data() + 64, head_end - 64));
  put64(16, XXH3_64bits(archive.data() + 64, archive.size() - 64));
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(XXH3_64bits(archive.data(), archive.size())));
  nlohmann::json m = nlohmann::json::parse(read_file(manifest));
  std::filesystem::remove(manifest.parent_path() / m["archive"]["file"].get<std::string>());
  const std::filesystem::path file = manifest.parent_path() / (m["name"].get<std::string>() + "." + hex + ".kpack");
  m["archive"]["file"] = file.filename().string();
  m["archive"]["size"] = archive.size();
  m["archive"]["xxh3_64"] = hex;
  std::ofstream(file, std::ios::binary) << archive;
  std::ofstream(manifest, std::ios::binary) << resealed_manifest(m.dump(1) + "\n");
  return file;
}

// The archive a pack manifest names (its "archive"/"file", next to the manifest).
inline std::filesystem::path archive_named_by(const std::filesystem::path& manifest) {
  return manifest.parent_path() / nlohmann::json::parse(read_file(manifest)).at("archive").at("file").get<std::string>();
}
inline std::string read_archive(const std::filesystem::path& manifest) { return read_file(archive_named_by(manifest)); }

// A corpus shader's "// stages:" header (tests/corpus) as a pack definition's "stages": "vertex=VSMain" names an entry
// point of the shader itself, "vertex=pairs/A.vert.hlsl:main" a file of the stage's own, relative to `corpus_dir`.
inline nlohmann::json corpus_stages(const std::string& header, const std::filesystem::path& corpus_dir) {
  nlohmann::json stages = nlohmann::json::object();
  std::istringstream words(header);
  for (std::string word; words >> word;) {
    const std::string stage = word.substr(0, word.find('=')), value = word.substr(word.find('=') + 1);
    if (const size_t colon = value.find(':'); colon != std::string::npos)
      stages[stage] = {{"source", (corpus_dir / value.substr(0, colon)).string()}, {"entry", value.substr(colon + 1)}};
    else
      stages[stage] = value;
  }
  return stages;
}

// A program running in the background (kiln watch), its standard output read line by line from a pipe as it writes
// them, its standard error into a file. A test waits on what it writes, never on time; the program is killed if the
// test ends first.
class BackgroundProcess {
 public:
  BackgroundProcess(const std::vector<std::string>& argv, const std::filesystem::path& cwd) {
    int out[2];
    if (::pipe2(out, O_CLOEXEC) != 0) return;
    const std::string err_path = (capture_ / "err").string();
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, out[1], 1);
    posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addchdir_np(&actions, cwd.c_str());
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    if (posix_spawn(&pid_, args[0], &actions, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
    ::close(out[1]);
    out_ = out[0];
  }
  BackgroundProcess(const BackgroundProcess&) = delete;
  BackgroundProcess& operator=(const BackgroundProcess&) = delete;
  ~BackgroundProcess() {
    if (pid_ > 0) end(SIGKILL);
    if (out_ >= 0) ::close(out_);
  }
  pid_t pid() const { return pid_; }

  // The next line it writes to standard output, without its newline; nothing when it closed its output first (it
  // ended), or after `limit`, which is no timing but a hung program failing its test rather than hanging it.
  std::optional<std::string> next_line(std::chrono::seconds limit = std::chrono::seconds(120)) {
    for (;;) {
      if (const size_t end = buffered_.find('\n'); end != std::string::npos) {
        std::string line = buffered_.substr(0, end);
        buffered_.erase(0, end + 1);
        return line;
      }
      pollfd entry{out_, POLLIN, 0};
      const int ready = ::poll(&entry, 1, static_cast<int>(limit.count() * 1000));
      if (ready < 0 && errno == EINTR) continue;
      if (ready <= 0) return std::nullopt;
      char buffer[4096];
      const ssize_t n = ::read(out_, buffer, sizeof buffer);
      if (n <= 0) return std::nullopt;
      buffered_.append(buffer, static_cast<size_t>(n));
    }
  }
  // Everything it wrote to standard error so far.
  std::string err() const { return read_file(capture_ / "err"); }
  // Its open file descriptors now (the entries of /proc/PID/fd).
  size_t open_descriptors() const {
    size_t count = 0;
    std::error_code ec;
    for (auto it = std::filesystem::directory_iterator("/proc/" + std::to_string(pid_) + "/fd", ec);
         !ec && it != std::filesystem::directory_iterator(); it.increment(ec))
      ++count;
    return count;
  }
  // Sends `signal` and waits for it to end: its exit status, 128 + the signal when a signal ended it.
  int end(int signal) {
    if (pid_ <= 0) return -1;
    ::kill(pid_, signal);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }

 private:
  TempDir capture_;
  pid_t pid_ = -1;
  int out_ = -1;
  std::string buffered_;
};

}  // namespace kiln::testing
