// SPDX-License-Identifier: Apache-2.0
// kiln render --watch: the image drawn again each time the pack it reads is replaced (kiln watch, kiln build), until
// SIGINT or SIGTERM. Event-driven and bounded (STYLE.md rule 19): it waits in one poll() on the reader's update
// descriptor and a signalfd; nothing sleeps, and each redraw makes the renderer anew on the one device it keeps.
#pragma once

#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "kiln/pack_reader.hpp"
#include "render/backend.hpp"

namespace kiln::render {

// Blocks SIGINT and SIGTERM in the calling thread, and so in every thread started after it (lavapipe's and llvmpipe's
// own), and returns a signalfd that reads them; -1 (errno set) when there is none. Call it before Backend::open: a
// thread that does not block them would take the signal and end the process in the middle of writing an image.
int block_stop_signals();

// Draws the frame with the variant selected now and writes its image; returns the keyword set it drew.
using DrawFrame = std::function<std::vector<std::string>()>;

struct WatchedFrame {
  std::string pass;                     // the pass that draws the image (the shadow maps are ShadowCaster's)
  std::vector<std::string> requested;   // the keywords asked for (--variant)
  std::vector<std::string> drawn;       // the keyword set drawn last (owned: it outlives a switch)
  std::string image;                    // the PNG's path, for the status lines
};

// After the first frame: waits for the pack to switch, and redraws (backend.reload(), then draw) when the switch
// changed a variant the frame draws, or made the selection give another one; one line per switch on `out`. A new
// pack the reader refuses, or a frame that cannot be drawn from it, prints its error and the image stays. Returns
// the exit status: 0 after SIGINT or SIGTERM, 3 when it cannot wait for the pack's updates.
int redraw_on_update(PackReader& pack, Backend& backend, int signal_fd, WatchedFrame frame, const DrawFrame& draw,
                     std::ostream& out);

}  // namespace kiln::render
