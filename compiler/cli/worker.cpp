// kiln-worker: a compiler worker process, started and fed by kiln's WorkerPool over stdin/stdout.
#include "workers/worker_pool.hpp"

int main(int argc, char** argv) { return kiln::worker_main(argc, argv); }
