// What a tool should feel, rendered from the world's raw per-tick reaction.
//
// The raw reaction (ToolFeedback) is the momentum the tool's pushes gave the
// mesh this tick, over dt. It is right on average (over time it equals the
// elastic reaction of the surface) but not tick by tick: a lightly pressed
// vertex is pushed out to just beyond the tool, drifts back in over a few
// ticks and is pushed again, so the force and the contact count toggle
// between zero and a multiple of the mean; and the first tick of a contact
// carries the impulse m·v of the vertices set to the tool's speed.
//
//   ContactRenderer r(1.0 / rate_hz);              // setup (no allocation afterwards)
//   const RenderedContact& c = r.update(world.feedback()[t], tool.position);   // every tick
//   r.reset();                                     // the tool went away (inactive, new scene)
//
// Per tick, in order:
//   1. contact state with hysteresis: touching from the first tick with raw
//      contacts; released only once there has been no raw contact for
//      `release_ticks` and the tool is `release_distance` from where it last
//      touched. An onset is a tick where touching turns on.
//   2. force: the raw impulses averaged over the last `window_ticks` (a box
//      filter of momentum: exact for any toggling period that divides the
//      window, within one impulse otherwise), then a one-pole low-pass of time
//      constant `smoothing`. Zero while not touching.
//   3. proxy: the surface point met at the onset slides with the tool along
//      the surface (only motion along the force's direction n counts), and the
//      tool's depth past it, δ, adds a spring `contact_stiffness`·δ along n.
//      The mesh alone is a shell of springs: its quasi-static reaction is tiny
//      for the first millimetres and not monotonic (a vertex's shallow dome
//      snaps through at about L²/2R deep); the proxy spring makes the felt
//      force rise with depth from the first touch, and keeps a resting tool
//      feeling the surface it rests on.
//   4. passivity controller (Hannaford & Ryu 2002): a lag on a spring force
//      returns more energy than it took. The energy the tool has put into the
//      environment since the onset, E = Σ −F·v·dt (v from successive poses),
//      is observed, and whenever the tick's force would make it negative a
//      damper along v takes out exactly the excess, so E ≥ 0 always. The
//      force is paired with the motion it answered (the tick's); a device
//      holds it while the tool makes the next tick's motion, so that pairing
//      is observed too and kept ≥ 0 on the guess that the next tick moves
//      like this one (exact for steady motion).
//
// Pure: no I/O, no allocation, deterministic (same inputs → same outputs).
#pragma once

#include <array>
#include <cstdint>

#include "sim/tool.hpp"

namespace sculpt::sim {

struct ContactRenderSettings {
  static constexpr int kMaxWindow = 256;
  int window_ticks = 64;            // box filter of impulses, ticks (≤ kMaxWindow)
  double smoothing = 0.02;          // s, one-pole low-pass after the box
  int release_ticks = 30;           // ticks with no raw contact before a release
  double release_distance = 5e-4;   // m from the last touching pose before a release
  double contact_stiffness = 5.0;   // N/m, the proxy spring (0: the filtered mesh reaction alone)
  double max_tool_speed = 20.0;     // m/s: faster between ticks is a teleport (no velocity, released)
};

struct RenderedContact {
  Vec3d force{};              // N, felt force on the tool
  std::uint32_t contacts = 0; // raw contacts this tick
  bool touching = false;      // in contact (with hysteresis)
  bool onset = false;         // touching turned on this tick
  double onset_impulse = 0;   // N·s, onset ticks only: the raw impulse of that tick (grows with approach speed)
  double depth = 0;           // m, the tool's depth past the proxy (δ)
  double damped = 0;          // J removed by the passivity controller this tick (≥ 0)
};

class ContactRenderer {
 public:
  explicit ContactRenderer(double dt, const ContactRenderSettings& settings = {});

  // One tick: the world's raw feedback for this tool and the tool's pose
  // (centre) this tick. Allocation-free.
  const RenderedContact& update(const ToolFeedback& raw, const Vec3d& tool_position);
  // Forget everything: the next update starts from no contact and no pose.
  void reset();

  const RenderedContact& last() const { return out_; }
  // The passivity observer's energy since the onset (J, ≥ 0).
  double energy() const { return energy_; }
  const ContactRenderSettings& settings() const { return settings_; }

 private:
  void update_contact_state(const ToolFeedback& raw, const Vec3d& p, bool teleported);
  void update_force(const ToolFeedback& raw, const Vec3d& v);
  void keep_passive(const Vec3d& v);

  double dt_;
  ContactRenderSettings settings_;
  RenderedContact out_;
  std::array<Vec3d, ContactRenderSettings::kMaxWindow> impulses_{};  // ring, N·s
  Vec3d impulse_sum_{};
  Vec3d smoothed_{};
  Vec3d normal_{};          // unit direction of the averaged reaction (surface → tool)
  int head_ = 0;
  bool have_pose_ = false;
  Vec3d pose_{};            // last tick's tool position
  Vec3d last_touch_{};      // tool position at the last tick with raw contacts
  int ticks_since_contact_ = 0;
  double energy_ = 0;        // observer: force with the tick's motion
  double energy_held_ = 0;   // observer: last tick's force with this tick's motion
  Vec3d held_force_{};
};

}  // namespace sculpt::sim
