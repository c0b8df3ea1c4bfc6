#include "simloop/compaction.hpp"

#include <fstream>

namespace sculpt::simloop {

std::optional<std::string> compaction_warning(std::string_view value) {
  const auto end = value.find_first_of(" \t\n");
  if (value.substr(0, end) != "1") return std::nullopt;
  return "--realtime: vm.compact_unevictable_allowed is 1: the kernel's compaction may move locked pages, and "
         "the sim thread waits mid-tick when it touches one (stats work_nvcsw); set it to 0 "
         "(sysctl vm.compact_unevictable_allowed=0) on a machine that sculpts";
}

std::string current_compact_unevictable_allowed() {
  std::ifstream f("/proc/sys/vm/compact_unevictable_allowed");
  std::string value;
  std::getline(f, value);
  return value;
}

}  // namespace sculpt::simloop
