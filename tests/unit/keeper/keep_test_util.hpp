// What the keeper tests share: where the sessions are, a fresh directory.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "support/sculpt_rig.hpp"

namespace sculpt::daemon::testing {

inline std::string session_path(const std::string& name) {
  return std::string(SCULPT_TEST_DATA) + "/sessions/" + name;
}

inline std::filesystem::path fresh_dir(const std::string& name) {
  const auto d = std::filesystem::path(::testing::TempDir()) /
                 ("keep-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace sculpt::daemon::testing
