// The contact renderer (sim/contact_render.hpp) against a real World<float>:
// the built-in scene's ball (icosphere r = 7 cm, 642 vertices, default rubber)
// and a 2 cm sphere tool coming down on its top along −y.
#include "sim/contact_render.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "sim/shapes.hpp"
#include "sim/world.hpp"

namespace sculpt::sim {
namespace {

constexpr double kDt = 1e-3;
constexpr double kBall = 0.07, kTool = 0.02;
constexpr double kTouchY = kBall + kTool;  // tool centre height at first touch (rest shape)

double norm(const Vec3d& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

// One ball, one tool, one renderer; keeps the energy the tool has put into
// the environment through the rendered force, E = Σ −F·v·dt.
struct Press {
  explicit Press(const Material& m = {}) : world(SimSettings{}, 1), render(kDt) {
    world.add_body(make_icosphere(float(kBall), 3), m);
    tool.radius = kTool;
    tool.position = {0, kTouchY + 0.002, 0};
    prev = tool.position;
  }
  const RenderedContact& step(double y) {
    tool.position = {0, y, 0};
    Tool tools[1] = {tool};
    world.step(tools);
    const RenderedContact& c = render.update(world.feedback()[0], tool.position);
    for (int k = 0; k < 3; ++k) {
      const double moved = tool.position[k] - prev[k];
      energy -= c.force[k] * moved;
      energy_held -= held[k] * moved;  // the force a device held while the tool made this move
      put_in += std::max(0.0, -c.force[k] * moved);
    }
    min_energy = std::min(min_energy, energy);
    min_energy_held = std::min(min_energy_held, energy_held);
    held = c.force;
    prev = tool.position;
    onsets += c.onset;
    raw_onsets += world.feedback()[0].onset;
    return c;
  }
  // Straight to height y at `speed`, then `hold` ticks there.
  void move_to(double y, double speed, int hold = 0) {
    double at = tool.position[1];
    while (at != y) {
      at = at > y ? std::max(y, at - speed * kDt) : std::min(y, at + speed * kDt);
      step(at);
    }
    for (int k = 0; k < hold; ++k) step(y);
  }
  World<float> world;
  ContactRenderer render;
  Tool tool;
  Vec3d prev{}, held{};
  double energy = 0, min_energy = 0, energy_held = 0, min_energy_held = 0, put_in = 0;
  int onsets = 0, raw_onsets = 0;
};

// std / mean of |F| over `ticks` ticks held at y.
double hold_cv(Press& p, double y, int ticks, double* mean_out = nullptr) {
  double s = 0, s2 = 0;
  for (int k = 0; k < ticks; ++k) {
    const double f = norm(p.step(y).force);
    s += f, s2 += f * f;
  }
  const double mean = s / ticks;
  if (mean_out) *mean_out = mean;
  return std::sqrt(std::max(0.0, s2 / ticks - mean * mean)) / mean;
}

TEST(ContactRender, SteadyPressGivesSteadyForce) {
  for (const double depth : {0.001, 0.002, 0.01, 0.02}) {
    Press p;
    p.move_to(kTouchY - depth, 0.02, 2000);
    double mean = 0;
    const double cv = hold_cv(p, kTouchY - depth, 1000, &mean);
    EXPECT_LT(cv, 0.10) << "depth " << depth;
    EXPECT_GT(mean, 0.0) << "depth " << depth;
  }
}

TEST(ContactRender, ForceRisesMonotonicallyWithDepthFromFirstTouch) {
  Press p;
  double y = kTouchY + 0.001;
  p.move_to(y, 0.02, 200);
  while (!p.render.last().touching) p.step(y -= 2e-5);  // creep down to the first touch
  // 0.25 mm steps to 6 mm, each settled for 0.8 s, then the mean of 0.3 s.
  // The mesh's own reaction dips here (a vertex's dome snaps through near
  // 0.6 mm and again near 4 mm): the proxy spring is what keeps this true.
  double last = 0;
  for (int step = 0; step < 24; ++step) {
    y -= 2.5e-4;
    p.move_to(y, 0.01, 800);
    double mean = 0;
    hold_cv(p, y, 300, &mean);
    if (step == 0) {
      EXPECT_GT(mean, 0.0);
    }
    EXPECT_GT(mean, last) << "step " << step;
    last = mean;
  }
}

TEST(ContactRender, RestingGivesNoOnsetsAfterTheFirst) {
  for (const double depth : {0.0001, 0.0005, 0.001}) {  // where the raw contacts toggle
    Press p;
    p.move_to(kTouchY - depth, 0.02, 100);
    ASSERT_EQ(p.onsets, 1);
    const int raw_before = p.raw_onsets;
    for (int k = 0; k < 2500; ++k) EXPECT_TRUE(p.step(kTouchY - depth).touching) << k;
    EXPECT_EQ(p.onsets, 1) << "depth " << depth;
    EXPECT_GT(p.raw_onsets - raw_before, 100) << "the raw contacts no longer toggle here: move the test";
  }
}

TEST(ContactRender, EachRealTouchGivesOneOnset) {
  Press p;
  for (int touch = 1; touch <= 3; ++touch) {
    p.move_to(kTouchY - 0.003, 0.05, 300);
    EXPECT_TRUE(p.render.last().touching);
    EXPECT_EQ(p.render.last().onset_impulse, 0.0);  // only on the onset tick
    p.move_to(kTouchY + 0.005, 0.05, 300);  // well clear, also of the surface ringing back
    EXPECT_FALSE(p.render.last().touching);
    EXPECT_EQ(p.onsets, touch);
    EXPECT_EQ(norm(p.render.last().force), 0.0);
  }
}

// Press/release cycles at several frequencies and amplitudes, then a rest:
// the energy put in through the felt force never goes below zero (the force
// paired with the tick's motion, as the observer pairs them).
TEST(ContactRender, CouplingNeverAddsEnergy) {
  for (const Material& m : {Material{}, [] {
                              Material clay;
                              clay.stiffness = 300, clay.damping = 0.3, clay.anchor = 4, clay.plastic = true;
                              clay.yield_strain = 0.01;
                              return clay;
                            }()}) {
    for (const double hz : {0.5, 2.0, 6.0}) {
      for (const double amplitude : {0.003, 0.012}) {
        Press p(m);
        p.move_to(kTouchY + 0.001, 0.05, 50);
        const int ticks = static_cast<int>(2.0 / hz / kDt);  // two cycles
        for (int k = 0; k <= ticks; ++k) {
          const double phase = 2 * M_PI * hz * k * kDt;
          p.step(kTouchY + 0.001 - (amplitude + 0.001) * 0.5 * (1 - std::cos(phase)));
        }
        p.move_to(kTouchY - amplitude / 2, 0.05, 500);  // and a resting hold
        EXPECT_GE(p.min_energy, -1e-12) << m.plastic << " " << hz << " Hz " << amplitude << " m";
        // Held one tick longer, the guard is a guess (steady motion): within 1% of what went in.
        EXPECT_GE(p.min_energy_held, -0.01 * p.put_in) << m.plastic << " " << hz << " Hz " << amplitude << " m";
        EXPECT_GT(p.energy, 0.0);
      }
    }
  }
}

// A tool swept fast through the ball (the sim's narrow phase sweeps): no
// vertex ever ends a tick inside it.
TEST(ContactRender, FastStrokesDoNotTunnel) {
  for (const double speed : {1.0, 5.0, 15.0}) {
    World<float> world(SimSettings{}, 1);
    world.add_body(make_icosphere(float(kBall), 3), Material{});
    std::vector<Vec3f> pos(world.body(0).n);
    Tool tool;
    tool.radius = kTool;
    double x = -0.15;
    int inside = 0, contacts = 0;
    for (int k = 0; x < 0.15; ++k) {
      x += speed * kDt;
      tool.position = {x, 0.04 * std::sin(k * 0.3), 0.02};
      Tool tools[1] = {tool};
      world.step(tools);
      contacts += world.feedback()[0].contacts;
      world.positions(0, pos);
      for (const Vec3f& q : pos) {
        const double d = std::hypot(q[0] - tool.position[0], q[1] - tool.position[1], q[2] - tool.position[2]);
        inside += d < kTool * (1 - 1e-5);
      }
    }
    EXPECT_EQ(inside, 0) << speed << " m/s";
    EXPECT_GT(contacts, 0) << speed << " m/s";
  }
}

TEST(ContactRender, SameInputsGiveTheSameBits) {
  auto run = [] {
    Press p;
    std::vector<RenderedContact> out;
    for (int k = 0; k < 1500; ++k) out.push_back(p.step(kTouchY + 0.002 - 0.01 * std::sin(k * 0.004)));
    return out;
  };
  const std::vector<RenderedContact> a = run(), b = run();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(std::memcmp(a[k].force.data(), b[k].force.data(), sizeof(Vec3d)), 0) << k;
    EXPECT_EQ(a[k].onset, b[k].onset);
    EXPECT_EQ(a[k].touching, b[k].touching);
  }
}

// Without a world: the box of impulses turns a raw force that toggles with
// any period dividing the window into its mean, and a reset forgets all.
TEST(ContactRender, TogglingImpulsesBecomeTheirMean) {
  ContactRenderer r(kDt);
  ToolFeedback raw;
  for (int k = 0; k < 2000; ++k) {
    const bool push = k % 4 == 0;
    raw.contacts = push;
    raw.force = {0, push ? 0.4 : 0.0, 0};
    r.update(raw, {0, 0, 0});
    EXPECT_TRUE(r.last().touching);
  }
  EXPECT_NEAR(r.last().force[1], 0.1, 1e-9);
  r.reset();
  EXPECT_FALSE(r.last().touching);
  EXPECT_EQ(r.last().force[1], 0.0);
}

// Lifting off slowly after a press: the felt force fades along the last
// normal and never turns round to pull the tool back (a direction taken from
// rounding residue once the window empties would).
TEST(ContactRender, LiftOffNeverPulls) {
  ContactRenderer r(kDt);
  ToolFeedback raw;
  double y = 0;
  for (int k = 0; k < 300; ++k) {
    raw.contacts = k % 3 == 0;
    raw.force = {0.001 * std::sin(k * 0.1), raw.contacts ? 0.3 + 0.1 * std::sin(k * 0.37) : 0.0, 0};
    r.update(raw, {0, y -= 1e-6, 0});
  }
  raw = {};
  for (int k = 0; k < 2000; ++k) {
    r.update(raw, {0, y += 5e-7, 0});
    ASSERT_GE(r.last().force[1], 0.0) << k;
  }
  EXPECT_FALSE(r.last().touching);
}

// A teleport (faster than any hand) is no velocity and ends the contact.
TEST(ContactRender, TeleportReleases) {
  ContactRenderer r(kDt);
  ToolFeedback raw;
  raw.contacts = 1;
  raw.force = {0, 0.1, 0};
  r.update(raw, {0, 0, 0});
  raw.contacts = 0;
  r.update(raw, {0, 0, 0});
  EXPECT_TRUE(r.last().touching);
  r.update(raw, {1, 0, 0});
  EXPECT_FALSE(r.last().touching);
  EXPECT_EQ(r.last().force[1], 0.0);
}

TEST(ContactRender, RejectsBadSettings) {
  EXPECT_THROW(ContactRenderer(0.0), std::invalid_argument);
  ContactRenderSettings s;
  s.window_ticks = ContactRenderSettings::kMaxWindow + 1;
  EXPECT_THROW(ContactRenderer(kDt, s), std::invalid_argument);
}

}  // namespace
}  // namespace sculpt::sim
