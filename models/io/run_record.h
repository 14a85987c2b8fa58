// What every output of this run records about how it was made (its provenance) and what
// went wrong without stopping it (its warnings). One per process: the CLI sets the command
// line at start; commands and checks add warnings, which are printed when raised and
// written into result.json, summary.json and every manifest (ssc.json).
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
// Prints "ssc: warning: MESSAGE" on stderr and records it (once per code and message).
void warn(const std::string& code, const std::string& message);
const std::vector<Warning>& warnings();
nlohmann::json warnings_json();
void clear_warnings();  // for tests

}  // namespace ssc
