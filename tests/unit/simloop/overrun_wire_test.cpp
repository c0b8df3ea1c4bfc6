// The overrun attribution reaches `sculptctl status --json` unchanged: the
// stats go through proto::Stats (minor 2, 3 and 4 fields) and come back as the same
// JSON object `sculptd --stats-json` writes.
#include <gtest/gtest.h>

#include <capnp/message.h>

#include <nlohmann/json.hpp>

#include "simloop/stats_json.hpp"
#include "server/encode.hpp"

namespace sculpt::simloop {
namespace {

TEST(OverrunStats, TravelThroughTheProtocolToTheSameJson) {
  server::DaemonStatus d;
  d.stats.rate_hz = 1000;
  d.stats.ticks = 30000;
  d.stats.overruns = 3;
  d.stats.overrun_causes = {2, 1};
  d.stats.long_steps_off_cpu = 1;
  for (std::uint64_t i = 0; i < 3; ++i) {
    OverrunRecord r;
    r.index = i;
    r.tick = 5000 + 17 * i;
    r.cause = i == 2 ? OverrunCause::long_step : OverrunCause::late_wake;
    r.off_cpu = i == 2;
    r.cpu = static_cast<int>(i % 2);
    r.late_ns = 1'234'567 + static_cast<std::int64_t>(i);
    r.stage_ns = {1'001, 120'003, 950'007 + i, 20'011};
    r.counters = {.work_cpu_ns = 1'100'013, .work_nvcsw = i % 2, .minflt = i, .majflt = 0, .nivcsw = 1,
                  .work_nvcsw_no_fault = i == 1 ? 0u : i % 2};
    d.stats.recent_overruns.push_back(r);
  }
  d.stats.sim_thread = {.work_cpu_ns = 0, .work_nvcsw = 2, .minflt = 12, .majflt = 0, .nivcsw = 4, .work_nvcsw_no_fault = 1};
  capnp::MallocMessageBuilder m;
  server::fill_stats(m.initRoot<proto::Stats>(), d);
  const StatsReading back = server::stats_from(m.getRoot<proto::Stats>().asReader());
  const nlohmann::json j = stats_json(back);
  EXPECT_EQ(j.dump(), stats_json(d.stats).dump());
  ASSERT_EQ(j["recent_overruns"].size(), 3u);
  EXPECT_EQ(j["recent_overruns"][2]["tick"], 5034);
  EXPECT_EQ(j["recent_overruns"][2]["cause"], "long_step");
  EXPECT_EQ(j["recent_overruns"][2]["off_cpu"], true);
  EXPECT_EQ(j["recent_overruns"][1]["cause"], "late_wake");
  EXPECT_EQ(j["overrun_causes"]["long_step_off_cpu"], 1);
  EXPECT_EQ(j["overrun_causes"]["late_wake"], 2);
  EXPECT_EQ(j["sim_thread"]["nivcsw"], 4);
  EXPECT_EQ(j["sim_thread"]["work_nvcsw"], 2);
  EXPECT_EQ(j["recent_overruns"][1]["work_nvcsw"], 1);
  EXPECT_EQ(j["recent_overruns"][1]["work_nvcsw_no_fault"], 0);
  EXPECT_EQ(j["sim_thread"]["work_nvcsw_no_fault"], 1);
}

TEST(OverrunStats, AnOlderDaemonsStatsReadAsNoAttribution) {
  // A minor-1 daemon never sets the new fields: they read as zeros and no records.
  capnp::MallocMessageBuilder m;
  auto st = m.initRoot<proto::Stats>();
  st.setOverruns(5);
  const StatsReading back = server::stats_from(st.asReader());
  EXPECT_EQ(back.overruns, 5u);
  EXPECT_EQ(back.overrun_causes[0] + back.overrun_causes[1], 0u);
  EXPECT_TRUE(back.recent_overruns.empty());
}

}  // namespace
}  // namespace sculpt::simloop
