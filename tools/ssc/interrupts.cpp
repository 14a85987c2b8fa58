// Clean ending on SIGINT/SIGTERM (see interrupts.h).
#include "tools/ssc/interrupts.h"

#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <thread>

#include "models/io/output_dir.h"

namespace ssc {

void handle_interrupts() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  std::thread([set] {
    int sig = 0;
    if (sigwait(&set, &sig) != 0) return;
    remove_unfinished_outputs(/*hold_until_exit=*/true);  // the command may still be writing
    std::fprintf(stderr, "\nssc: interrupted by %s; removed the unfinished output\n", sig == SIGINT ? "SIGINT" : "SIGTERM");
    std::fflush(stderr);
    _exit(128 + sig);
  }).detach();
}

}  // namespace ssc
