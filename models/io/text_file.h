// Writes a whole text file and checks that it reached the disk; an input/output error naming
// the file and the reason otherwise (write_error.h).
#pragma once
#include <string>

namespace ssc {

void write_text_file(const std::string& path, const std::string& text);

}  // namespace ssc
