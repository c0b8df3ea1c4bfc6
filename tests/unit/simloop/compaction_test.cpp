// The compaction setting, as --realtime reads it to warn that locked pages may move.
#include <gtest/gtest.h>

#include "simloop/compaction.hpp"

namespace sculpt::simloop {
namespace {

TEST(Compaction, WarnsOnlyWhenLockedPagesMayMove) {
  for (const char* moves : {"1", "1\n"}) {
    const auto w = compaction_warning(moves);
    ASSERT_TRUE(w) << moves;
    EXPECT_NE(w->find("vm.compact_unevictable_allowed=0"), std::string::npos) << *w;
  }
  // 0 keeps locked pages in place; "" is a kernel without compaction (or no /proc).
  for (const char* fine : {"0", "0\n", "", "10"}) EXPECT_FALSE(compaction_warning(fine)) << fine;
}

TEST(Compaction, ThisMachinesSettingIsReadableOrAbsent) {
  const std::string v = current_compact_unevictable_allowed();
  EXPECT_TRUE(v == "" || v == "0" || v == "1") << v;
}

}  // namespace
}  // namespace sculpt::simloop
