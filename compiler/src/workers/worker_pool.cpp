// SPDX-License-Identifier: Apache-2.0
#include "workers/worker_pool.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <deque>
#include <numeric>
#include <new>
#include <thread>

extern char** environ;

#ifndef KILN_BUILD_WORKER_PATH
#define KILN_BUILD_WORKER_PATH ""
#endif

namespace kiln {

struct WorkerPool::Worker {
  pid_t pid = -1;
  int to_worker = -1;
  int from_worker = -1;
  long job = -1;  // index of the job in flight
  std::chrono::steady_clock::time_point started;
  std::vector<uint8_t> buffer;
  WorkerActivity activity;  // of this slot, across restarts
};

namespace {

bool write_all(int fd, const uint8_t* data, size_t size) {
  while (size > 0) {
    ssize_t put = ::write(fd, data, size);
    if (put < 0 && errno == EINTR) continue;
    if (put <= 0) return false;
    data += put;
    size -= static_cast<size_t>(put);
  }
  return true;
}

bool read_all(int fd, uint8_t* data, size_t size) {
  while (size > 0) {
    ssize_t got = ::read(fd, data, size);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) return false;
    data += got;
    size -= static_cast<size_t>(got);
  }
  return true;
}

// Messages are a 4-byte little-endian length followed by CBOR.
bool write_message(int fd, const std::vector<uint8_t>& payload) {
  uint8_t header[4];
  for (int i = 0; i < 4; ++i) header[i] = static_cast<uint8_t>(payload.size() >> (8 * i));
  return write_all(fd, header, 4) && write_all(fd, payload.data(), payload.size());
}

std::string describe_status(int status) {
  if (WIFSIGNALED(status)) {
    int signal = WTERMSIG(status);
    return "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  }
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  return "stopped unexpectedly";
}

}  // namespace

std::filesystem::path default_worker_executable() {
  if (const char* env = std::getenv("KILN_WORKER"); env && *env) return env;
  std::error_code ec;
  auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    auto sibling = self.parent_path() / "kiln-worker";
    if (std::filesystem::exists(sibling, ec)) return sibling;
    auto libexec = self.parent_path().parent_path() / "libexec" / "kiln" / "kiln-worker";
    if (std::filesystem::exists(libexec, ec)) return libexec;
  }
  return KILN_BUILD_WORKER_PATH;
}

WorkerPool::WorkerPool(std::filesystem::path executable, unsigned workers, WorkerLimits limits)
    : executable_(std::move(executable)), count_(std::max(1u, workers)), limits_(limits) {
  // A worker that dies while we write its job must not kill us with SIGPIPE.
  ::signal(SIGPIPE, SIG_IGN);
}

WorkerPool::~WorkerPool() {
  for (Worker* worker : workers_) {
    stop(*worker, false);
    delete worker;
  }
}

Result<void> WorkerPool::spawn(Worker& worker) {
  int in_pipe[2], out_pipe[2];
  if (::pipe2(in_pipe, O_CLOEXEC) != 0) return failure(std::string("pipe: ") + std::strerror(errno));
  if (::pipe2(out_pipe, O_CLOEXEC) != 0) {
    const int error = errno;
    ::close(in_pipe[0]);
    ::close(in_pipe[1]);
    return failure(std::string("pipe: ") + std::strerror(error));
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, in_pipe[0], 0);
  posix_spawn_file_actions_adddup2(&actions, out_pipe[1], 1);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  std::string memory = std::to_string(limits_.memory_limit_mb);
  std::string exe = executable_.string();
  char* argv[] = {exe.data(), const_cast<char*>("--memory-limit-mb"), memory.data(),
                  const_cast<char*>("--frontend"), limits_.frontend.data(), nullptr};
  pid_t pid = -1;
  int rc = posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(in_pipe[0]);
  ::close(out_pipe[1]);
  if (rc != 0) {
    ::close(in_pipe[1]);
    ::close(out_pipe[0]);
    return failure("cannot start compiler worker '" + exe + "': " + std::strerror(rc));
  }
  worker.pid = pid;
  worker.to_worker = in_pipe[1];
  worker.from_worker = out_pipe[0];
  worker.buffer.clear();
  worker.job = -1;
  if (worker.activity.jobs == 0 && !worker.activity.compiled) worker.activity.spawned = std::chrono::steady_clock::now();
  ++spawned_;
  return {};
}

void WorkerPool::stop(Worker& worker, bool kill_now) {
  if (worker.pid < 0) return;
  if (worker.to_worker >= 0) ::close(worker.to_worker);  // EOF on stdin: the worker exits
  if (kill_now) ::kill(worker.pid, SIGKILL);
  int status = 0;
  ::waitpid(worker.pid, &status, 0);
  if (worker.from_worker >= 0) ::close(worker.from_worker);
  worker.pid = -1;
  worker.to_worker = worker.from_worker = -1;
  worker.job = -1;
  worker.buffer.clear();
}

std::vector<WorkerActivity> WorkerPool::activity() const {
  std::vector<WorkerActivity> out;
  for (const Worker* worker : workers_)
    if (worker->activity.jobs > 0) out.push_back(worker->activity);
  return out;
}

void WorkerPool::run(std::vector<CompileJob>& jobs, const std::function<void(size_t, WorkerOutcome)>& on_done,
                     const ExternalWork* external) {
  // The timeline: a job is in flight from its hand-out to its result (or its worker's death).
  auto started_job = [&](Worker& worker) {
    worker.started = std::chrono::steady_clock::now();
    if (jobs[static_cast<size_t>(worker.job)].kind == JobKind::Preprocess || worker.activity.compiled) return;
    worker.activity.compiled = true;
    worker.activity.first_compile = worker.started;
    worker.activity.preprocessing_before_compile = worker.activity.preprocessing;
  };
  auto ended_job = [&](Worker& worker) {
    const auto now = std::chrono::steady_clock::now();
    (jobs[static_cast<size_t>(worker.job)].kind == JobKind::Preprocess ? worker.activity.preprocessing
                                                                        : worker.activity.compiling) += now - worker.started;
    worker.activity.last_done = now;
    ++worker.activity.jobs;
  };
  std::deque<size_t> ready(jobs.size());
  std::iota(ready.begin(), ready.end(), size_t{0});
  size_t known = jobs.size(), finished = 0;
  // Jobs appended by on_done go to the front of the queue: a follow-up carries a finished job's result,
  // which is released as soon as it runs.
  auto take_appended = [&] {
    for (size_t i = jobs.size(); i > known; --i) ready.push_front(i - 1);
    known = jobs.size();
  };
  auto finish = [&](size_t index, WorkerOutcome outcome) {
    ++finished;
    on_done(index, std::move(outcome));
    take_appended();
  };
  auto external_pending = [&] { return external && external->pending(); };
  auto timing_of = [&](const Worker& worker) {
    JobTiming timing;
    timing.slot = static_cast<unsigned>(std::find(workers_.begin(), workers_.end(), &worker) - workers_.begin());
    timing.sent = worker.started;
    timing.answered = std::chrono::steady_clock::now();
    return timing;
  };
  auto fail_job = [&](Worker& worker, WorkerOutcome::Kind kind, std::string detail, bool kill_now) {
    JobTiming timing = timing_of(worker);
    ended_job(worker);
    size_t index = static_cast<size_t>(worker.job);
    worker.job = -1;
    int status = 0;
    if (kill_now) ::kill(worker.pid, SIGKILL);
    if (worker.to_worker >= 0) ::close(worker.to_worker);
    ::waitpid(worker.pid, &status, 0);
    ::close(worker.from_worker);
    worker.pid = -1;
    worker.to_worker = worker.from_worker = -1;
    if (detail.empty()) detail = describe_status(status);
    WorkerOutcome outcome;
    outcome.kind = kind;
    outcome.detail = std::move(detail);
    outcome.timing = std::move(timing);
    finish(index, std::move(outcome));
  };

  // An interruption (WorkerLimits::interrupted) ends the jobs not handed out yet; those in flight finish.
  bool interrupted = false;
  auto cancel_ready = [&] {
    while (!ready.empty()) {
      const size_t next = ready.front();
      ready.pop_front();
      WorkerOutcome outcome;
      outcome.kind = WorkerOutcome::Kind::Cancelled;
      outcome.detail = "not run: the build was interrupted";
      finish(next, std::move(outcome));  // may append follow-ups: ended the same way
    }
  };
  auto ask_interrupted = [&] {
    if (!interrupted && limits_.interrupted && limits_.interrupted()) interrupted = true;
    if (interrupted) cancel_ready();
  };

  while (finished < jobs.size() || external_pending()) {
    if (!ready.empty()) ask_interrupted();
    while (workers_.size() < std::min<size_t>(count_, jobs.size())) workers_.push_back(new Worker);
    // Hand out work to idle workers.
    for (Worker* worker : workers_) {
      if (worker->job >= 0 || ready.empty()) continue;
      size_t next = ready.front();
      ready.pop_front();
      if (Result<void> spawned = worker->pid < 0 ? spawn(*worker) : Result<void>(); !spawned) {
        WorkerOutcome outcome;
        outcome.kind = WorkerOutcome::Kind::Failed;
        outcome.detail = spawned.error().message;
        finish(next, std::move(outcome));
        continue;
      }
      worker->job = static_cast<long>(next);
      started_job(*worker);
      if (!write_message(worker->to_worker, encode_job(jobs[static_cast<size_t>(worker->job)])))
        fail_job(*worker, WorkerOutcome::Kind::Crashed, "", false);
    }
    // Wait for a result, a death or a deadline.
    std::vector<pollfd> fds;
    std::vector<Worker*> polled;
    auto now = std::chrono::steady_clock::now();
    auto wait = limits_.job_timeout;
    for (Worker* worker : workers_) {
      if (worker->job < 0) continue;
      fds.push_back({worker->from_worker, POLLIN, 0});
      polled.push_back(worker);
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(worker->started + limits_.job_timeout - now);
      wait = std::min(wait, std::max(left, std::chrono::milliseconds(0)));
    }
    const bool waits_outside = external_pending();
    if (waits_outside) fds.push_back({external->fd, POLLIN, 0});
    if (fds.empty()) continue;
    // What may interrupt the build, while it can (not once interrupted: nothing reads those descriptors then).
    const size_t interrupt_at = fds.size();
    if (!interrupted && limits_.interrupted)
      for (int fd : limits_.interrupt_fds) fds.push_back({fd, POLLIN, 0});
    int polled_count = ::poll(fds.data(), fds.size(), static_cast<int>(wait.count()) + 1);
    if (polled_count < 0 && errno != EINTR) break;
    now = std::chrono::steady_clock::now();
    if (fds.size() > interrupt_at) {
      const bool readable = polled_count > 0 && std::any_of(fds.begin() + static_cast<long>(interrupt_at), fds.end(),
                                                            [](const pollfd& entry) { return entry.revents != 0; });
      fds.resize(interrupt_at);
      if (readable) ask_interrupted();
    }
    if (waits_outside) {
      const bool arrived = polled_count > 0 && (fds.back().revents & POLLIN);
      fds.pop_back();
      if (arrived) {
        external->arrived();
        take_appended();
      }
    }
    for (size_t i = 0; i < fds.size(); ++i) {
      Worker& worker = *polled[i];
      if (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) {
        uint8_t chunk[1 << 16];
        ssize_t got = ::read(worker.from_worker, chunk, sizeof chunk);
        if (got <= 0) {
          fail_job(worker, WorkerOutcome::Kind::Crashed, "", false);
          continue;
        }
        worker.buffer.insert(worker.buffer.end(), chunk, chunk + got);
        if (worker.buffer.size() >= 4) {
          size_t length = 0;
          for (int b = 0; b < 4; ++b) length |= static_cast<size_t>(worker.buffer[b]) << (8 * b);
          if (worker.buffer.size() >= 4 + length) {
            std::vector<uint8_t> payload(worker.buffer.begin() + 4, worker.buffer.begin() + 4 + static_cast<long>(length));
            worker.buffer.erase(worker.buffer.begin(), worker.buffer.begin() + 4 + static_cast<long>(length));
            JobTiming timing = timing_of(worker);
            ended_job(worker);
            size_t index = static_cast<size_t>(worker.job);
            worker.job = -1;
            WorkerOutcome outcome;
            try {
              outcome.output = decode_output(payload);
              timing.steps = std::move(outcome.output.steps);
              timing.steps_elapsed_us = outcome.output.steps_elapsed_us;
              outcome.output.steps.clear();
              outcome.timing = std::move(timing);
              if (outcome.output.failed_step == CompileStep::OutOfMemory) {
                outcome.kind = WorkerOutcome::Kind::OutOfMemory;
                outcome.detail = "exceeded the memory limit of " + std::to_string(limits_.memory_limit_mb) + " MiB";
                stop(worker, true);  // its heap may be in any state: start a fresh one
              }
            } catch (const std::exception& error) {
              outcome.kind = WorkerOutcome::Kind::Crashed;
              outcome.detail = std::string("sent a malformed result: ") + error.what();
              outcome.timing = std::move(timing);
              stop(worker, true);
            }
            finish(index, std::move(outcome));
          }
        }
      } else if (now - worker.started >= limits_.job_timeout) {
        fail_job(worker, WorkerOutcome::Kind::TimedOut,
                 "did not finish within " + std::to_string(limits_.job_timeout.count() / 1000.0).substr(0, 5) + " s",
                 true);
      }
    }
  }
}

int worker_main(int argc, char** argv, void (*before_job)(CompileJob& job)) {
  std::string frontend_name{kDefaultFrontend};
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "--memory-limit-mb") {
      rlim_t bytes = static_cast<rlim_t>(std::stoull(argv[i + 1])) << 20;
      rlimit limit{bytes, bytes};
      ::setrlimit(RLIMIT_AS, &limit);
    } else if (std::string(argv[i]) == "--frontend") {
      frontend_name = argv[i + 1];
    }
  }
  auto frontend = make_frontend(frontend_name);
  if (!frontend) return 3;  // the build checks the name first; a worker of another kiln version could differ
  for (;;) {
    uint8_t header[4];
    if (!read_all(0, header, 4)) return 0;  // the parent closed our stdin: done
    size_t length = 0;
    for (int b = 0; b < 4; ++b) length |= static_cast<size_t>(header[b]) << (8 * b);
    std::vector<uint8_t> payload(length);
    if (!read_all(0, payload.data(), length)) return 1;
    JobOutput output;
    try {
      CompileJob job = decode_job(payload);
      if (before_job) before_job(job);
      output = run_compile_job(*frontend, job);
    } catch (const std::bad_alloc&) {
      output = JobOutput{};
      output.failed_step = CompileStep::OutOfMemory;
    } catch (const std::exception& error) {
      output = JobOutput{};
      output.failed_step = CompileStep::Internal;
      output.messages.push_back({Severity::Error, "", 0, error.what()});
    }
    std::vector<uint8_t> encoded;
    try {
      encoded = encode_output(output, /*with_steps=*/true);
    } catch (const std::bad_alloc&) {
      JobOutput oom;
      oom.failed_step = CompileStep::OutOfMemory;
      encoded = encode_output(oom);
    }
    if (!write_message(1, encoded)) return 1;
  }
}

}  // namespace kiln
