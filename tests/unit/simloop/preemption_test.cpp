// The kernel's preemption model, as --realtime reads it to warn when a woken
// SCHED_FIFO thread would wait for other tasks' system calls.
#include <gtest/gtest.h>

#include "simloop/preemption.hpp"

namespace sculpt::simloop {
namespace {

TEST(Preemption, ReadsTheBuildThenTheDynamicModeThenTheBootParameter) {
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_RT Sat Nov 1", "", ""), "rt");
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT Debian 6.1.0", "", ""), "full");
  EXPECT_EQ(preemption_model("#1 SMP Debian 6.1.0", "", ""), "none");
  // A dynamic kernel: debugfs brackets the current mode...
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_DYNAMIC @0", "none voluntary (full) lazy\n", "preempt=none"), "full");
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_DYNAMIC @0", "(none) voluntary full lazy\n", ""), "none");
  // ...else the boot parameter says, else nobody can tell.
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_DYNAMIC @0", "", "console=ttyS0 preempt=voluntary quiet\n"), "voluntary");
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_DYNAMIC @0", "", "console=ttyS0 quiet\n"), "");
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_DYNAMIC @0", "", "xpreempt=full"), "");
  // ...else the build's default from its config (debugfs needs root).
  const char* config = "CONFIG_PREEMPT_BUILD=y\n# CONFIG_PREEMPT_NONE is not set\nCONFIG_PREEMPT_VOLUNTARY=y\n"
                       "# CONFIG_PREEMPT is not set\nCONFIG_PREEMPT_COUNT=y\nCONFIG_PREEMPT_DYNAMIC=y\n";
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_DYNAMIC @0", "", "quiet\n", config), "voluntary");
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_DYNAMIC @0", "", "preempt=full\n", config), "full");
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_DYNAMIC @0", "", "", "CONFIG_PREEMPT_DYNAMIC=y\nCONFIG_PREEMPT=y\n"),
            "full");
  EXPECT_EQ(preemption_model("#1 SMP PREEMPT_DYNAMIC @0", "", "", "CONFIG_PREEMPT_DYNAMIC=y\n"), "");
  // "PREEMPT" inside another word is not the flag.
  EXPECT_EQ(preemption_model("#1 SMP NOPREEMPTION", "", ""), "none");
}

TEST(Preemption, WarnsOnlyWhenRealTimeWakeUpsWait) {
  for (const char* fine : {"rt", "full", "lazy"}) EXPECT_FALSE(preemption_warning(fine)) << fine;
  for (const char* slow : {"none", "voluntary"}) {
    const auto w = preemption_warning(slow);
    ASSERT_TRUE(w) << slow;
    EXPECT_NE(w->find(slow), std::string::npos) << *w;
    EXPECT_NE(w->find("preempt=full"), std::string::npos) << *w;
  }
  const auto unknown = preemption_warning("");
  ASSERT_TRUE(unknown);
  EXPECT_NE(unknown->find("cannot be read"), std::string::npos) << *unknown;
}

TEST(Preemption, ThisMachinesModelIsOneOfTheKnownOnes) {
  const std::string m = current_preemption_model();
  EXPECT_TRUE(m == "" || m == "rt" || m == "full" || m == "lazy" || m == "voluntary" || m == "none") << m;
}

}  // namespace
}  // namespace sculpt::simloop
