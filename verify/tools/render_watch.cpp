// SPDX-License-Identifier: Apache-2.0
#include "tools/render_watch.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>

#include "scene/scene.hpp"
#include "scene/verify_error.hpp"

namespace kiln::render {

int block_stop_signals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  if (::pthread_sigmask(SIG_BLOCK, &signals, nullptr) != 0) return -1;
  return ::signalfd(-1, &signals, SFD_NONBLOCK | SFD_CLOEXEC);
}

namespace {

// A status line names at most this many changed variants, then how many more: a pack switch that touches every
// variant of a large pack still prints one short line.
constexpr size_t kNamedChanges = 8;

const char* change_kind(VariantChange::Kind kind) {
  switch (kind) {
    case VariantChange::Kind::Added: return "added";
    case VariantChange::Kind::Changed: return "changed";
    case VariantChange::Kind::Removed: return "removed";
    case VariantChange::Kind::Moved: return "moved";
  }
  return "?";
}

std::string list_changes(const PackUpdate& update) {
  if (update.changes.empty()) return "no variant changed";
  std::string text;
  for (size_t i = 0; i < update.changes.size() && i < kNamedChanges; ++i) {
    const VariantChange& change = update.changes[i];
    text += (i ? ", " : "") + change.pass + " " + variant_name(change.keywords) + " " + change_kind(change.kind);
  }
  if (update.changes.size() > kNamedChanges) text += " and " + std::to_string(update.changes.size() - kNamedChanges) + " more";
  return text;
}

// Whether the switch touches what the frame draws: its variant (by keyword set, in its pass) or any shadow caster
// (the frame's shadow maps are drawn with one or two of them). A Moved variant has the same code.
bool touches_frame(const PackUpdate& update, const WatchedFrame& frame) {
  if (update.ids_changed) return true;
  return std::any_of(update.changes.begin(), update.changes.end(), [&](const VariantChange& change) {
    if (change.kind == VariantChange::Kind::Moved) return false;
    return change.pass == "ShadowCaster" || (change.pass == frame.pass && change.keywords == frame.drawn);
  });
}

std::string seconds_since(std::chrono::steady_clock::time_point start) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f s",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return text;
}

}  // namespace

int redraw_on_update(PackReader& pack, Backend& backend, int signal_fd, WatchedFrame frame, const DrawFrame& draw,
                     std::ostream& out) {
  PackResult<int> update_fd = pack.update_fd();
  if (!update_fd) {
    std::cerr << "kiln: error: cannot wait for the pack's updates: " << update_fd.message() << "\n";
    return 3;
  }
  out << "kiln render: watching the pack; " << frame.image << " is drawn again when it changes (Ctrl-C ends)\n"
      << std::flush;
  pollfd fds[2] = {{*update_fd, POLLIN, 0}, {signal_fd, POLLIN, 0}};
  for (;;) {
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      std::cerr << "kiln: error: cannot wait for the pack's updates: poll: " << std::strerror(errno) << "\n";
      return 3;
    }
    if (fds[1].revents & POLLIN) {
      signalfd_siginfo info{};
      const ssize_t got = ::read(signal_fd, &info, sizeof info);
      out << "kiln render: " << (got == sizeof info ? strsignal(static_cast<int>(info.ssi_signo)) : "signal")
          << ": stopped; " << frame.image << " holds the last frame\n" << std::flush;
      return 0;
    }
    if (fds[0].revents & (POLLERR | POLLNVAL)) {
      std::cerr << "kiln: error: the pack's update descriptor failed\n";
      return 3;
    }
    if (!(fds[0].revents & POLLIN)) continue;
    const auto woken = std::chrono::steady_clock::now();
    PackResult<PackUpdate> update = pack.poll_update();  // drains the descriptor
    if (!update) {
      report(pack_error(update.error()));
      out << "kiln render: the new pack is refused; " << frame.image << " keeps the last frame\n" << std::flush;
      continue;
    }
    if (!update->switched) continue;  // the archive written, its manifest not yet renamed: the next wake switches
    const std::string head = "kiln render: pack version " + std::to_string(update->version) + " (" + update->archive +
                             "): " + list_changes(*update);
    bool redraw = touches_frame(*update, frame);
    if (!redraw) {
      // An Added variant may now be the better match for the keywords asked for.
      try {
        redraw = pack.select(frame.pass, frame.requested).keywords != frame.drawn;
      } catch (const PackError&) {
        redraw = true;  // let the redraw report why it cannot select
      }
    }
    if (!redraw) {
      out << head << "; none that this frame draws, " << frame.image << " kept\n" << std::flush;
      continue;
    }
    try {
      backend.reload();
      frame.drawn = draw();
      out << head << "; redrew " << frame.image << " (" << frame.pass << " " << variant_name(frame.drawn) << ") in "
          << seconds_since(woken) << "\n" << std::flush;
    } catch (const VerifyError& e) {
      report(e);
      out << head << "; cannot draw the frame from it, " << frame.image << " keeps the last frame\n" << std::flush;
    } catch (const PackError& e) {
      report(pack_error(e));
      out << head << "; cannot draw the frame from it, " << frame.image << " keeps the last frame\n" << std::flush;
    }
  }
}

}  // namespace kiln::render
