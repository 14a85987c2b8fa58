// SHA-256 (FIPS 180-4), used to name generated kernels and to key the kernel cache.
// Small, dependency-free and deterministic across platforms.
#pragma once
#include <string>

namespace ssc {

// Lower-case hex digest (64 characters) of the bytes of `data`.
std::string sha256_hex(const std::string& data);

}  // namespace ssc
