// What every output of this run records about how it was made (its provenance) and what
// went wrong without stopping it (its warnings). One per process: the CLI sets the command
// line at start; commands and checks add warnings, which are written into result.json,
// summary.json and every manifest (ssc.json), and printed on stderr: when raised, or, once the
// CLI holds them (hold_warnings), all together at the end of the command, where progress lines
// cannot bury them.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace ssc {

void set_command_line(int argc, const char* const* argv);
// command_line, ssc_version, ssc_commit, host, started (ISO 8601, UTC).
nlohmann::json run_provenance();
std::string utc_time_now();

struct Warning {
  std::string code;     // stable name, e.g. "unsegmented_depth"
  std::string message;  // what was seen and what to do
};
// Records the warning (once per code and message) and prints "ssc: warning: MESSAGE" on
// stderr, unless warnings are held.
void warn(const std::string& code, const std::string& message);
// From now on warn() only records (hold = false: prints again); print_held_warnings() prints
// each recorded warning that was not printed yet, once.
void hold_warnings(bool hold = true);
void print_held_warnings();
const std::vector<Warning>& warnings();
nlohmann::json warnings_json();
void clear_warnings();  // for tests

}  // namespace ssc
