// SIGINT and SIGTERM end a run cleanly: the unfinished output folders and locks are removed
// (models/io/output_dir.h) and the process exits with the conventional status 128 + signal
// (130, 143). The signals are blocked in every thread and taken by one watcher thread, so
// the clean-up runs as ordinary code, not inside a signal handler.
#pragma once

namespace ssc {

// Call first in main, before any thread (OpenMP, CUDA) starts: threads inherit the mask.
void handle_interrupts();

}  // namespace ssc
