// What the keeper tests share: where the recordings are, a fresh directory.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "support/scratch_dir.hpp"
#include "support/sculpt_rig.hpp"

namespace sculpt::daemon::testing {

inline std::string recording_path(const std::string& name) {
  return std::string(SCULPT_TEST_DATA) + "/recordings/" + name;
}

inline std::filesystem::path fresh_dir(const std::string& name) { return support::fresh_scratch_dir("keep-" + name); }

}  // namespace sculpt::daemon::testing
