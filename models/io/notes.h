// Notes: what the user should know about a run that is neither its result nor a warning (the
// device it runs on, a value ssc adjusted to the input). One line "ssc: ..." on stderr each,
// silenced by --quiet; unlike warnings (run_record.h) they are not recorded in the outputs.
#pragma once
#include <string>

namespace ssc {

void note(const std::string& line);
// Prints the line only the first time it is given (for what each of several loads repeats).
void note_once(const std::string& line);
void set_quiet(bool quiet);
bool quiet();

}  // namespace ssc
