// What the store fuzzer and its seed generator share: a tiny scene (the
// default scene's rubber ball, smaller, and its left tool), a store's
// stored forms (a stroke as the keeper writes it), and the input's format.
//
// An input is one mode byte, then:
//   'F'  a .sculpt file (an SQLite database), recovered as `sculptd --open` does
//   'P'  sections that alter a store made from the base sculpt before it is
//        recovered: [kind u8][length u16 LE][payload], kind one of
//          'S' u32 offset + bytes  patch the state     'B' u32 offset + bytes  patch the bundle
//          'K' u32 offset + bytes  add a stroke, patched  'M' text  the meta
//          'J' u16 ticks + bytes   a journal record that many ticks after the snapshot
//          'T' u32 ticks           the snapshot row's tick moved on
//   'R'  sections 'S' only: the patched state restored on a replica and stepped
//   'I'  u32 body, u32 block, u32 offset + bytes: a block image, patched; swapped in if it passes
//   'Z'  u8 codec, u32 size, then a blob: store::decode within a 1 MiB cap
//   'U'  a scene bundle's bytes: SceneBundle::from_bytes
//   'E'  a journal record's bytes: decode_entry
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "keeper/history.hpp"
#include "keeper/replica.hpp"
#include "keeper/scene_bundle.hpp"
#include "sim/state_bytes.hpp"

namespace sculpt::fuzz {

inline constexpr std::string_view kTinyScene = R"toml(version = 1

[simulation]
rate_hz = 1000
substeps = "auto"

[[mesh]]
name = "ball"
file = "builtin:icosphere"
params = { radius = 0.07, subdivisions = 2 }
material = "rubber"
position = [-0.2, 0.0, 0.0]

[[tool]]
name = "left"
shape = "sphere"
radius = 0.02
device = 0
stick = "left"
position = [-0.15, 0.15, 0.05]
)toml";

inline std::shared_ptr<daemon::SceneBundle> tiny_bundle() {
  auto b = std::make_shared<daemon::SceneBundle>();
  b->file = "tiny.toml";
  b->text = std::string(kTinyScene);
  return b;
}

// A stroke as the keeper stores it (keeper/snapshots.cpp).
inline std::vector<std::byte> stroke_bytes(const daemon::Stroke& s) {
  std::vector<std::byte> out;
  sim::StateWriter w(out);
  w.value(s.number), w.value(s.scene), w.value(s.body), w.value(s.summary), w.value(s.vertices);
  w.value(static_cast<std::uint8_t>(s.undone)), w.value(static_cast<std::uint64_t>(s.image_bytes));
  w.array(std::span<const char>(s.mesh.data(), s.mesh.size()));
  w.array(s.blocks), w.array(s.images);
  return out;
}

// The base sculpt the 'P', 'R' and 'I' inputs alter: the tiny scene stepped
// a little, as a snapshot (state, meta, bundle) with one stroke of the ball's
// first two blocks (their images as the world has them).
struct Base {
  std::shared_ptr<daemon::SceneBundle> bundle = tiny_bundle();
  daemon::History history{std::uint64_t{4} << 20};  // what stepping the replica records, bounded
  std::unique_ptr<daemon::Replica> replica;
  std::vector<std::byte> bundle_bytes, state, stroke;
  std::string bundle_key = "bundle/fuzz", stroke_key = "stroke/fuzz-1";
  nlohmann::json meta;

  Base() {
    replica = std::make_unique<daemon::Replica>(bundle, daemon::load_bundle(*bundle), 1, 0, history);
    replica->advance_to(20);
    state = replica->state();
    bundle_bytes = bundle->bytes();
    const sim::World<float>& w = replica->world();
    daemon::Stroke s;
    s.number = 1;
    s.scene = 1;
    s.body = 0;
    s.mesh = "ball";
    s.summary = {1, 0, 2, 1};
    s.image_bytes = w.block_image_bytes(0);
    for (std::uint32_t k = 0; k < std::min<std::uint32_t>(2, w.body(0).blocks); ++k) {
      std::vector<std::byte> image(s.image_bytes);
      w.block_image(0, k, image);
      s.blocks.push_back(k);
      s.vertices += w.body(0).end_of(k) - w.body(0).begin_of(k);
      s.images.insert(s.images.end(), image.begin(), image.end());
    }
    stroke = stroke_bytes(s);
    meta = {{"format", 1},        {"scene", 1},           {"next_scene", 2},
            {"scene_file", "tiny.toml"}, {"bundle", bundle_key}, {"first_tick", 0},
            {"next_tick", replica->next_tick()}, {"paused", false}, {"next_stroke", 2},
            {"dropped", 0},       {"strokes", nlohmann::json::array({stroke_key})}};
  }
};

// Appends a section of a 'P' or 'R' input.
inline void section(std::vector<std::uint8_t>& in, char kind, std::span<const std::uint8_t> payload) {
  in.push_back(static_cast<std::uint8_t>(kind));
  in.push_back(static_cast<std::uint8_t>(payload.size() & 0xff));
  in.push_back(static_cast<std::uint8_t>(payload.size() >> 8));
  in.insert(in.end(), payload.begin(), payload.end());
}

}  // namespace sculpt::fuzz
