// Writes a whole text file and checks that it reached the disk; InputError naming the file.
#pragma once
#include <string>

namespace ssc {

void write_text_file(const std::string& path, const std::string& text);

}  // namespace ssc
