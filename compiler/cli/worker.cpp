// SPDX-License-Identifier: Apache-2.0
// kiln-worker: a compiler worker process, started and fed by kiln's WorkerPool over stdin/stdout.
#include <iostream>
#include <string_view>

#include "allocator.hpp"
#include "workers/worker_pool.hpp"

int main(int argc, char** argv) {
  if (argc == 2 && std::string_view(argv[1]) == "--version") {
    std::cout << "kiln-worker, allocator: " << kiln::allocator_description() << "\n";
    return 0;
  }
  return kiln::worker_main(argc, argv);
}
