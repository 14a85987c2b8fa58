// A fingerprint of a folder's files (the observations a result was fitted to), for
// manifests: FNV-1a 64 over every regular file's relative path and bytes, in sorted order.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

namespace ssc {

// {"path", "files", "bytes", "fnv1a64"}; InputError if the folder cannot be read.
nlohmann::json folder_fingerprint(const std::string& folder);

}  // namespace ssc
