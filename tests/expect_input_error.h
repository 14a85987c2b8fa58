// Test helper: runs fn and expects an ssc::InputError whose message contains every string
// in `parts` (the file, the key, the fix), so that error tests check what the user reads.
#pragma once
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

#include "runtime/errors.h"

namespace ssc {

inline void expect_input_error(const std::function<void()>& fn, const std::vector<std::string>& parts) {
  try {
    fn();
    ADD_FAILURE() << "no InputError thrown; expected one mentioning " << parts.front();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    for (const std::string& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
  }
}

}  // namespace ssc
