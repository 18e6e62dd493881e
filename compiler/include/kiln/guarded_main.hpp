// SPDX-License-Identifier: Apache-2.0
// The one guarded entry point of kiln's executables (kiln, kiln-verify): an exception that escapes `run` is an
// internal error, exit 2, with the "this is a bug in kiln" wording; never an abort, nor an exit code that reads
// as the input's fault.
#pragma once

#include <exception>
#include <iostream>
#include <new>

namespace kiln {

template <typename Run>
int run_guarded(Run&& run) noexcept {
  constexpr const char* kBug = "\n  note: this is a bug in kiln, not in your input: please report it with the command line\n";
  try {
    return run();
  } catch (const std::bad_alloc&) {
    std::cerr << "kiln: error: out of memory\n";
  } catch (const std::exception& error) {
    std::cerr << "kiln: internal error: " << error.what() << kBug;
  } catch (...) {
    std::cerr << "kiln: internal error: an unknown exception" << kBug;
  }
  return 2;
}

}  // namespace kiln
