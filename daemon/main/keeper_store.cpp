// Keeper: what goes into a snapshot (the replica's state, the scene bundle,
// the strokes, as blobs by content) and recovery from it.
#include <chrono>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "main/journal_codec.hpp"
#include "main/keeper.hpp"
#include "main/log.hpp"
#include "sim/state_bytes.hpp"

namespace sculpt::daemon {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kMetaFormat = 1;

std::uint64_t fnv1a(std::span<const std::byte> bytes) {
  std::uint64_t h = 1469598103934665603ull;
  for (std::byte b : bytes) h = (h ^ static_cast<std::uint64_t>(b)) * 1099511628211ull;
  return h;
}

// Content-addressed: a key is never reused for other bytes.
std::string blob_key(const char* kind, std::span<const std::byte> bytes) {
  return fmt::format("{}/{:016x}-{}", kind, fnv1a(bytes), bytes.size());
}

std::vector<std::byte> stroke_bytes(const Stroke& s) {
  std::vector<std::byte> out;
  sim::StateWriter w(out);
  w.value(s.number), w.value(s.scene), w.value(s.body), w.value(s.edit), w.value(s.vertices);
  w.value(static_cast<std::uint8_t>(s.undone)), w.value(static_cast<std::uint64_t>(s.image_bytes));
  w.array(std::span<const char>(s.mesh.data(), s.mesh.size()));
  w.array(s.blocks), w.array(s.images);
  return out;
}

template <class T>
std::vector<T> read_vector(sim::StateReader& r, const char* what) {
  std::uint64_t n = 0;
  r.value(n, what);
  if (n > r.left() / sizeof(T)) throw std::invalid_argument(std::string("truncated in ") + what);
  std::vector<T> v(n);
  r.raw(v.data(), n * sizeof(T), what);
  return v;
}

Stroke stroke_from(std::span<const std::byte> bytes) {
  sim::StateReader r(bytes, /*dry=*/false);
  Stroke s;
  std::uint8_t undone = 0;
  std::uint64_t image_bytes = 0;
  r.value(s.number, "stroke"), r.value(s.scene, "stroke"), r.value(s.body, "stroke"), r.value(s.edit, "stroke");
  r.value(s.vertices, "stroke"), r.value(undone, "stroke"), r.value(image_bytes, "stroke");
  s.undone = undone != 0;
  s.image_bytes = image_bytes;
  const std::vector<char> mesh = read_vector<char>(r, "stroke mesh");
  s.mesh.assign(mesh.begin(), mesh.end());
  s.blocks = read_vector<std::uint32_t>(r, "stroke blocks");
  s.images = read_vector<std::byte>(r, "stroke images");
  if (!r.done() || s.images.size() != s.blocks.size() * s.image_bytes)
    throw std::invalid_argument("stroke images do not match its blocks");
  return s;
}

}  // namespace

// A scene's start as a snapshot of no state: recovery builds the scene's
// world fresh from the bundle at `first_tick` and replays from there.
void Keeper::write_scene_start(const JournalEntry& e) {
  std::shared_ptr<const SceneBundle> bundle;
  std::uint32_t next_scene = 0;
  {
    std::lock_guard lock(mutex_);
    const auto it = incoming_.find(e.edit);
    if (it == incoming_.end()) return;
    bundle = it->second.bundle;
    next_scene = next_scene_;
  }
  const std::vector<std::byte> bytes = bundle->bytes();
  const std::string key = blob_key("bundle", bytes);
  const nlohmann::json meta = {{"format", kMetaFormat}, {"fresh", true},          {"scene", e.edit},
                               {"next_scene", next_scene}, {"scene_file", bundle->file}, {"bundle", key},
                               {"first_tick", e.tick},   {"next_tick", e.tick},    {"paused", false},
                               {"next_stroke", 1},       {"dropped", 0},           {"strokes", nlohmann::json::array()}};
  const std::vector<store::BlobWrite> blobs{{key, bytes}};
  const std::vector<std::string> refs{key};
  store::Status st;
  try {
    const store::PreparedSnapshot prepared = store_.prepare_snapshot(e.tick, {}, meta.dump(), blobs, refs);
    std::lock_guard store_lock(store_mutex_);
    st = store_.write_snapshot(prepared);
  } catch (const std::bad_alloc&) {
    st = store::Status{false, false, "no memory to compress the scene's files"};
  }
  std::lock_guard lock(mutex_);
  if (!st.ok && !st.deferred && st.error != last_store_error_) {
    log::warning("autosave: the start of scene {}: {}; the sculpt goes on in memory and the store is retried",
                 bundle->file, st.error);
    last_store_error_ = st.error;
  }
}

void Keeper::snapshot(const char* why) {
  if (!replica_) return;
  next_snapshot_ = Clock::now() + settings_.snapshot_every;
  replayed_since_snapshot_ = {};
  const auto began = Clock::now();
  const std::vector<std::byte> state = replica_->state();
  std::vector<std::vector<std::byte>> owned;
  std::vector<store::BlobWrite> blobs;
  std::vector<std::string> refs;
  if (bundle_key_.empty() || !bundle_stored_) {
    owned.push_back(replica_->bundle()->bytes());
    bundle_key_ = blob_key("bundle", owned.back());
    blobs.push_back({bundle_key_, owned.back()});
  }
  refs.push_back(bundle_key_);
  for (std::uint32_t n : history_.take_gone()) stroke_keys_.erase(n), unsaved_.erase(n);
  for (std::uint32_t n : history_.take_changed()) unsaved_.insert(n);
  std::map<std::uint32_t, std::string> keys;  // this snapshot's
  nlohmann::json strokes = nlohmann::json::array();
  for (const Stroke& s : history_.strokes()) {
    auto known = stroke_keys_.find(s.number);
    if (known == stroke_keys_.end() || unsaved_.count(s.number)) {
      owned.push_back(stroke_bytes(s));
      keys[s.number] = blob_key("stroke", owned.back());
      blobs.push_back({keys[s.number], owned.back()});
    } else {
      keys[s.number] = known->second;
    }
    refs.push_back(keys[s.number]);
    strokes.push_back(keys[s.number]);
  }
  std::uint32_t next_scene = 0;
  {
    std::lock_guard lock(mutex_);
    next_scene = next_scene_;
  }
  const nlohmann::json meta = {{"format", kMetaFormat},
                               {"scene", replica_->scene_number()},
                               {"next_scene", next_scene},
                               {"scene_file", replica_->bundle()->file},
                               {"bundle", bundle_key_},
                               {"first_tick", replica_->first_tick()},
                               {"next_tick", replica_->next_tick()},
                               {"paused", replica_->paused()},
                               {"next_stroke", history_.next_number()},
                               {"dropped", history_.dropped()},
                               {"strokes", strokes}};
  // Compressed without the store: the journal thread's commits go on meanwhile.
  store::Status st;
  store::Health health;
  std::uint64_t stored = 0;
  try {
    const store::PreparedSnapshot prepared = store_.prepare_snapshot(replica_->next_tick(), state, meta.dump(), blobs, refs);
    stored = prepared.data.size();
    for (const auto& b : prepared.blobs) stored += b.data.size();
    std::lock_guard store_lock(store_mutex_);
    st = store_.write_snapshot(prepared);
    health = store_.health();
  } catch (const std::bad_alloc&) {
    st = store::Status{false, false, "no memory to compress the snapshot"};
  }
  std::lock_guard lock(mutex_);
  ++stats_.snapshots;
  stats_.snapshot_state_bytes = state.size();
  stats_.snapshot_stored_bytes = stored;
  stats_.snapshot_ms = std::chrono::duration<double, std::milli>(Clock::now() - began).count();
  health_ = health;
  if (st.ok) {
    bundle_stored_ = true;
    stroke_keys_ = std::move(keys);
    unsaved_.clear();
    log::debug("autosave: snapshot ({}) at tick {}: {} bytes of state, {} new blobs, {:.1f} ms", why,
               replica_->next_tick(), state.size(), blobs.size(),
               std::chrono::duration<double, std::milli>(Clock::now() - began).count());
  } else if (!st.deferred && st.error != last_store_error_) {
    log::warning("autosave: {}; the sculpt goes on in memory and the store is retried", st.error);
    last_store_error_ = st.error;
  }
}

std::optional<Recovered> Keeper::recover() {
  const auto began = Clock::now();
  store::Recovery rec = store_.recover();
  Recovered out;
  out.lost = std::move(rec.lost);
  if (!rec.snapshot) {
    if (!rec.journal.empty() || !out.lost.empty()) {
      for (const auto& l : out.lost) log::warning("recovery: {}", l);
      log::warning("recovery: {} has no usable snapshot; starting anew", store_.database().string());
    }
    return std::nullopt;
  }
  try {
    const std::string error = recover_from(*rec.snapshot, rec.journal, out);
    if (!error.empty()) out.lost.push_back(error);
  } catch (const std::exception& e) {
    log::warning("recovery: {}: {}; starting anew", store_.database().string(), e.what());
    replica_.reset();
    history_.restore({}, history_.next_number(), history_.dropped());
    return std::nullopt;
  }
  out.seconds = std::chrono::duration<double>(Clock::now() - began).count();
  return out;
}

// The snapshot's scene and state, then the journal after it replayed.
// Throws when the snapshot itself cannot be used; returns what stopped the
// replay early ("" when it went to the end).
std::string Keeper::recover_from(store::Snapshot& snap, std::vector<store::Record>& journal, Recovered& out) {
  const nlohmann::json meta = nlohmann::json::parse(snap.meta);
  if (meta.at("format").get<int>() != kMetaFormat)
    throw std::invalid_argument(fmt::format("snapshot format {}, this sculptd reads {}", meta.at("format").get<int>(), kMetaFormat));
  const auto blob = [&snap](const std::string& key) -> const std::vector<std::byte>& {
    const auto it = snap.blobs.find(key);
    if (it == snap.blobs.end()) throw std::invalid_argument("the snapshot's " + key + " is missing");
    return it->second;
  };
  auto bundle = std::make_shared<const SceneBundle>(SceneBundle::from_bytes(blob(meta.at("bundle").get<std::string>())));
  scene::Scene scene = load_bundle(*bundle);
  std::deque<Stroke> strokes;
  for (const auto& key : meta.at("strokes")) {
    strokes.push_back(stroke_from(blob(key.get<std::string>())));
    stroke_keys_[strokes.back().number] = key.get<std::string>();
  }
  out.strokes = strokes.size();
  history_.restore(std::move(strokes), meta.at("next_stroke").get<std::uint32_t>(), meta.at("dropped").get<std::uint64_t>());
  next_scene_ = meta.at("next_scene").get<std::uint32_t>();
  const std::uint32_t number = meta.at("scene").get<std::uint32_t>();
  replica_ = std::make_unique<Replica>(bundle, scene, number, meta.at("first_tick").get<std::uint64_t>(), history_);
  if (!meta.value("fresh", false)) replica_->restore_state(snap.state);
  bundle_key_ = meta.at("bundle").get<std::string>();
  bundle_stored_ = true;
  out.snapshot_tick = replica_->next_tick();
  std::string stopped;
  std::uint64_t target = replica_->next_tick();  // ticks before it are done
  for (const store::Record& rec : journal) {
    std::string why;
    const auto e = decode_entry(rec.bytes, rec.tick - 1, why);
    if (!e) {
      stopped = fmt::format("a journal record of tick {} is unreadable ({}): the sculpt is recovered as it was before it",
                            rec.tick - 1, why);
      break;
    }
    if (e->kind == JournalEntry::Kind::scene && e->edit == number) continue;  // the snapshot's own scene start
    if (e->kind == JournalEntry::Kind::scene) {
      stopped = fmt::format("the scene loaded at tick {} was not saved before the daemon ended: the sculpt is "
                            "recovered as it was before that load", e->tick);
      break;
    }
    // A mark, a message or an edit of tick t: the sim thread ran t. A pause
    // or resume of tick t came before it.
    const bool before = e->kind == JournalEntry::Kind::pause || e->kind == JournalEntry::Kind::resume;
    target = std::max(target, before ? e->tick : e->tick + 1);
    if (e->kind == JournalEntry::Kind::reached) {
      out.committed_ns = std::max(out.committed_ns, e->wall_ns);
      continue;
    }
    const std::string error = replica_->apply(*e);
    if (!error.empty()) out.lost.push_back(error);
    ++out.replayed;
  }
  replica_->advance_to(target);  // strokes the replay made or swapped go into the next snapshot
  out.bundle = bundle;
  out.scene = std::move(scene);
  out.state = replica_->state();
  out.first_tick = replica_->first_tick();
  out.next_tick = replica_->next_tick();
  out.paused = replica_->paused();
  out.hash = replica_->world().hash();
  publish_history();
  return stopped;
}

}  // namespace sculpt::daemon
