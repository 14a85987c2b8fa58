// Notes on stderr (see notes.h).
#include "models/io/notes.h"

#include <atomic>
#include <cstdio>
#include <mutex>
#include <set>

namespace ssc {
namespace {
std::atomic<bool> quiet_notes{false};
std::mutex mutex;
std::set<std::string> given;
}  // namespace

void set_quiet(bool quiet) { quiet_notes = quiet; }
bool quiet() { return quiet_notes; }

void note(const std::string& line) {
  if (!quiet_notes) std::fprintf(stderr, "ssc: %s\n", line.c_str());
}

void note_once(const std::string& line) {
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (!given.insert(line).second) return;
  }
  note(line);
}

}  // namespace ssc
