// Keeper: what goes into a snapshot (the replica's state, the scene bundle,
// the strokes, as blobs by content) and recovery from it.
#include <algorithm>
#include <chrono>
#include <stdexcept>

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
// The scene's files as a bundle, at most: its text (1 MiB at most) and its
// meshes. Recovery reads no larger one, so none is written.
constexpr std::uint64_t kMaxBundleBytes = std::uint64_t{256} << 20;

void check_bundle_size(std::size_t bytes) {
  if (bytes > kMaxBundleBytes)
    throw std::length_error(fmt::format("the scene's files are {} bytes, more than a store keeps ({}): the sculpt is "
                                        "not saved",
                                        bytes, kMaxBundleBytes));
}

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
  if (!r.done() || s.image_bytes > s.images.size() || s.images.size() != s.blocks.size() * s.image_bytes)
    throw std::invalid_argument(fmt::format("stroke {}: its images do not match its blocks", s.number));
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
    check_bundle_size(bytes.size());
    const store::PreparedSnapshot prepared = store_.prepare_snapshot(e.tick, {}, meta.dump(), blobs, refs);
    std::lock_guard store_lock(store_mutex_);
    st = store_.write_snapshot(prepared);
  } catch (const std::exception& e) {  // no memory to compress them, or more than a store holds
    st = store::Status{false, false, e.what()};
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
    for (const store::BlobWrite& b : blobs)
      if (b.key == bundle_key_) check_bundle_size(b.bytes.size());
    const store::PreparedSnapshot prepared = store_.prepare_snapshot(replica_->next_tick(), state, meta.dump(), blobs, refs);
    stored = prepared.data.size();
    for (const auto& b : prepared.blobs) stored += b.data.size();
    std::lock_guard store_lock(store_mutex_);
    st = store_.write_snapshot(prepared);
    health = store_.health();
  } catch (const std::exception& e) {  // no memory to compress it, or more than a store holds
    st = store::Status{false, false, e.what()};
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

// --- recovery: everything read is checked before it is used ---------------------------

namespace {

constexpr std::uint64_t kMaxTick = std::uint64_t{1} << 62;  // ~1.5e8 years of ticks at 1 kHz
// A stroke's blob beyond its images and blocks: the fields, the length prefixes, the mesh name (scene_bundle's cap).
constexpr std::uint64_t kStrokeOverhead = 128 + 4096;
constexpr std::uint64_t kTicksBetweenChecks = 16;  // of the clock and of stop_requested, while stepping
constexpr std::size_t kRecordsBetweenChecks = 256;

[[noreturn]] void refuse(const std::string& why) { throw std::invalid_argument(why); }

const nlohmann::json& meta_at(const nlohmann::json& meta, const char* key) {
  const auto it = meta.find(key);
  if (it == meta.end()) refuse(fmt::format("its meta has no \"{}\"", key));
  return *it;
}

std::uint64_t meta_uint(const nlohmann::json& meta, const char* key, std::uint64_t lo, std::uint64_t hi) {
  const nlohmann::json& v = meta_at(meta, key);
  if (!v.is_number_unsigned()) refuse(fmt::format("its meta's \"{}\" is {}, not a count", key, v.dump()));
  const std::uint64_t x = v.get<std::uint64_t>();
  if (x < lo || x > hi) refuse(fmt::format("its meta's \"{}\" is {}, not within [{}, {}]", key, x, lo, hi));
  return x;
}

bool meta_bool(const nlohmann::json& meta, const char* key) {
  const nlohmann::json& v = meta_at(meta, key);
  if (!v.is_boolean()) refuse(fmt::format("its meta's \"{}\" is {}, not true or false", key, v.dump()));
  return v.get<bool>();
}

std::string meta_string(const nlohmann::json& meta, const char* key, std::size_t max) {
  const nlohmann::json& v = meta_at(meta, key);
  if (!v.is_string() || v.get_ref<const std::string&>().size() > max)
    refuse(fmt::format("its meta's \"{}\" is not a string of at most {} bytes", key, max));
  return v.get<std::string>();
}

// A stroke of the running scene fits its world: its body and mesh, its
// blocks (each once), its image size, and every image a block can hold.
void check_stroke(const Stroke& s, const sim::World<float>& world, const scene::Scene& scene) {
  const std::string at = fmt::format("stroke {}: ", s.number);
  if (s.body >= world.body_count())
    refuse(at + fmt::format("mesh {} of a scene of {}", s.body, world.body_count()));
  if (s.mesh != scene.meshes[s.body].name)
    refuse(at + fmt::format("mesh {} is \"{}\", not \"{}\"", s.body, s.mesh, scene.meshes[s.body].name));
  const sim::Body<float>& b = world.body(s.body);
  if (s.image_bytes != world.block_image_bytes(s.body))
    refuse(at + fmt::format("images of {} bytes, the mesh's are {}", s.image_bytes, world.block_image_bytes(s.body)));
  std::vector<std::uint32_t> sorted = s.blocks;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) refuse(at + "a block twice");
  std::uint64_t vertices = 0;
  for (std::size_t i = 0; i < s.blocks.size(); ++i) {
    const std::uint32_t k = s.blocks[i];
    if (k >= b.blocks) refuse(at + fmt::format("block {} of a mesh of {}", k, b.blocks));
    vertices += b.end_of(k) - b.begin_of(k);
    const std::string error = world.block_image_error(
        s.body, k, std::span<const std::byte>(s.images).subspan(i * s.image_bytes, s.image_bytes));
    if (!error.empty()) refuse(at + error);
  }
  if (vertices != s.vertices) refuse(at + fmt::format("{} vertices, its blocks hold {}", s.vertices, vertices));
}

}  // namespace

// The strokes the snapshot lists (oldest first), newest first back to what
// the budget and the count hold, exactly as History::fit_budget would keep
// them: a blob is read only when it could still fit, so a file cannot make
// recovery build more than the history holds. `dropped`: the older ones.
std::deque<Stroke> Keeper::read_strokes(const store::StoredSnapshot& snap, const nlohmann::json& keys,
                                        std::uint32_t next_stroke, std::uint64_t& dropped) {
  if (!keys.is_array()) refuse("its meta's \"strokes\" is not a list");
  std::deque<Stroke> strokes;
  std::uint64_t used = 0;
  std::size_t i = keys.size();
  for (; i > 0 && strokes.size() < history_.max_strokes(); --i) {
    const nlohmann::json& k = keys[i - 1];
    if (!k.is_string()) refuse("its meta lists a stroke that is not a key");
    const std::string& key = k.get_ref<const std::string&>();
    const auto size = snap.blobs.find(key);
    if (size == snap.blobs.end()) refuse(fmt::format("blob {} is missing", key));
    const std::uint64_t room = history_.budget() - used;
    if (size->second > room + kStrokeOverhead) break;  // its images alone would not fit
    std::string why;
    const auto bytes = store_.read_blob(key, room + kStrokeOverhead, why);
    if (!bytes) refuse(why);
    Stroke s = stroke_from(*bytes);
    if (s.bytes() > room) break;
    used += s.bytes();
    stroke_keys_[s.number] = key;
    strokes.push_front(std::move(s));
  }
  dropped = i;
  std::uint32_t previous = 0;
  bool undone = false;
  for (const Stroke& s : strokes) {
    if (s.number <= previous || s.number >= next_stroke)
      refuse(fmt::format("stroke {} is out of order (after {}, before the next, {})", s.number, previous, next_stroke));
    if (!s.undone && undone) refuse(fmt::format("stroke {} is done after an undone one", s.number));
    if (s.edit.first_tick > s.edit.last_tick || s.edit.last_tick > kMaxTick)
      refuse(fmt::format("stroke {}: ticks {} to {}", s.number, s.edit.first_tick, s.edit.last_tick));
    previous = s.number;
    undone = s.undone;
  }
  return strokes;
}

// The snapshot as a replica and a history, everything checked: its meta
// field by field, the scene bundle (the settings as a config's, the sizes
// within their caps) and the scene built from it, the state's size against
// the scene before it is decoded and its values by the world's own checks,
// the strokes against the budget before they are read and against the
// world after. Throws std::invalid_argument (or what building the scene
// throws) naming what is wrong.
void Keeper::use_snapshot(const store::StoredSnapshot& snap, Recovered& out) {
  nlohmann::json meta;
  try {
    meta = nlohmann::json::parse(snap.meta);
  } catch (const nlohmann::json::exception& e) {
    refuse(fmt::format("its meta is not JSON ({})", e.what()));
  }
  if (!meta.is_object()) refuse("its meta is not a JSON object");
  const std::uint64_t format = meta_uint(meta, "format", 0, UINT32_MAX);
  if (format != kMetaFormat) refuse(fmt::format("snapshot format {}, this sculptd reads {}", format, kMetaFormat));
  const bool fresh = meta.contains("fresh") && meta_bool(meta, "fresh");
  const auto number = static_cast<std::uint32_t>(meta_uint(meta, "scene", 1, UINT32_MAX - 1));
  const auto next_scene = static_cast<std::uint32_t>(meta_uint(meta, "next_scene", number + 1, UINT32_MAX));
  const std::string bundle_key = meta_string(meta, "bundle", 1024);
  const std::uint64_t first_tick = meta_uint(meta, "first_tick", 0, kMaxTick);
  const std::uint64_t next_tick = meta_uint(meta, "next_tick", first_tick, kMaxTick);
  if (next_tick != snap.tick) refuse(fmt::format("its meta is of tick {}, its row of tick {}", next_tick, snap.tick));
  const bool paused = meta_bool(meta, "paused");
  const auto next_stroke = static_cast<std::uint32_t>(meta_uint(meta, "next_stroke", 1, UINT32_MAX));
  const std::uint64_t dropped = meta_uint(meta, "dropped", 0, UINT64_MAX / 2);

  const auto bundle_size = snap.blobs.find(bundle_key);
  if (bundle_size == snap.blobs.end()) refuse(fmt::format("blob {} is missing", bundle_key));
  if (bundle_size->second > kMaxBundleBytes)
    refuse(fmt::format("its scene bundle is {} bytes, more than the cap of {}", bundle_size->second, kMaxBundleBytes));
  // The snapshots before it share the bundle (its key names its bytes): one
  // refused is not read, and its scene not built, again.
  if (const auto was = refused_bundles_.find(bundle_key); was != refused_bundles_.end())
    refuse(fmt::format("its scene bundle was refused above ({})", was->second));
  std::string why;
  std::shared_ptr<const SceneBundle> bundle;
  scene::Scene scene;
  try {
    {
      const auto bytes = store_.read_blob(bundle_key, kMaxBundleBytes, why);
      if (!bytes) refuse(why);
      bundle = std::make_shared<const SceneBundle>(SceneBundle::from_bytes(*bytes));
    }
    scene = load_bundle(*bundle);
    replica_ = std::make_unique<Replica>(bundle, scene, number, first_tick, history_);
  } catch (const std::exception& e) {
    refused_bundles_[bundle_key] = e.what();
    throw;
  }
  if (fresh) {
    if (snap.raw_size != 0 || first_tick != next_tick) refuse("a scene's start holds a state");
  } else {
    // Its size against the scene's before a byte of it is decoded.
    const std::size_t expected = replica_->state().size();
    if (snap.raw_size != expected)
      refuse(fmt::format("its state is {} bytes, the scene's is {}", snap.raw_size, expected));
    const auto state = store_.read_state(snap, expected, why);
    if (!state) refuse(why);
    replica_->restore_state(*state);
    if (replica_->first_tick() != first_tick || replica_->next_tick() != next_tick || replica_->paused() != paused)
      refuse(fmt::format("its state is of tick {} from tick {}{}, its meta says tick {} from tick {}{}",
                         replica_->next_tick(), replica_->first_tick(), replica_->paused() ? " (paused)" : "",
                         next_tick, first_tick, paused ? " (paused)" : ""));
  }
  std::uint64_t older = 0;
  std::deque<Stroke> strokes = read_strokes(snap, meta_at(meta, "strokes"), next_stroke, older);
  for (const Stroke& s : strokes) {
    if (s.scene == number) check_stroke(s, replica_->world(), scene);
    else if (s.scene == 0 || s.scene > number) refuse(fmt::format("stroke {} is of scene {}", s.number, s.scene));
  }
  out.strokes = strokes.size();
  history_.restore(std::move(strokes), next_stroke, dropped + older);
  next_scene_ = next_scene;
  bundle_key_ = bundle_key;
  bundle_stored_ = true;
  out.bundle = bundle;
  out.scene = std::move(scene);
  out.snapshot_tick = replica_->next_tick();
}

// Steps the replica to `tick`, looking at the clock and `stop_requested`
// every few ticks; false when the deadline came first.
bool Keeper::advance_replica(std::uint64_t tick, Clock::time_point deadline, const std::function<bool()>& stop_requested) {
  while (replica_->next_tick() < tick) {
    if (stop_requested && stop_requested())
      throw RecoveryStopped(fmt::format("recovery stopped at tick {} of the replay", replica_->next_tick()));
    if (Clock::now() >= deadline) return false;
    replica_->advance_to(std::min(tick, replica_->next_tick() + kTicksBetweenChecks));
  }
  return true;
}

// The journal after the snapshot, replayed within the bounds: a record that
// does not decode, one further on than replay_span_limit, a scene that was
// not saved, or the wall clock past replay_time_limit stops the replay
// there. Returns what stopped it ("" when it went to the end).
std::string Keeper::replay(const std::vector<store::Record>& journal, const std::function<bool()>& stop_requested,
                           Recovered& out) {
  const std::uint32_t number = replica_->scene_number();
  const std::uint64_t from = replica_->next_tick();
  const double span_ticks = static_cast<double>(settings_.replay_span_limit.count()) * replica_->rate();
  const auto deadline = Clock::now() + settings_.replay_time_limit;
  const std::uint64_t last = journal.empty() ? from : journal.back().tick - 1;
  auto out_of_time = [&] {
    return fmt::format("the replay was stopped after {:.0f} s (the cap) at tick {}, {} ticks short of the journal's "
                       "last, {}: the sculpt is recovered as it was there",
                       std::chrono::duration<double>(settings_.replay_time_limit).count(), replica_->next_tick(),
                       last > replica_->next_tick() ? last - replica_->next_tick() : 0, last);
  };
  std::uint64_t target = from;  // ticks before it are done
  std::size_t seen = 0;
  for (const store::Record& rec : journal) {
    if (stop_requested && ++seen % kRecordsBetweenChecks == 0 && stop_requested())
      throw RecoveryStopped(fmt::format("recovery stopped at tick {} of the replay", replica_->next_tick()));
    const std::uint64_t tick = rec.tick - 1;  // store ticks are global ticks + 1; every record's is > the snapshot's
    if (static_cast<double>(tick - from) > span_ticks)
      return fmt::format("a journal record of tick {} is {} ticks after the snapshot of tick {}: more than the {} s "
                         "({:.0f} ticks at {:g} Hz) a recovery replays; the sculpt is recovered as it was before it",
                         tick, tick - from, from, settings_.replay_span_limit.count(), span_ticks, replica_->rate());
    std::string why;
    const auto e = decode_entry(rec.bytes, tick, why);
    if (!e)
      return fmt::format("a journal record of tick {} is unreadable ({}): the sculpt is recovered as it was before it",
                         tick, why);
    if (e->kind == JournalEntry::Kind::scene && e->edit == number) continue;  // the snapshot's own scene start
    if (e->kind == JournalEntry::Kind::scene)
      return fmt::format("the scene loaded at tick {} was not saved before the daemon ended: the sculpt is "
                         "recovered as it was before that load", e->tick);
    // A mark, a message or an edit of tick t: the sim thread ran t. A pause
    // or resume of tick t came before it.
    const bool before = e->kind == JournalEntry::Kind::pause || e->kind == JournalEntry::Kind::resume;
    target = std::max(target, before ? e->tick : e->tick + 1);
    if (e->kind == JournalEntry::Kind::reached) {
      out.committed_ns = std::max(out.committed_ns, e->wall_ns);
      continue;
    }
    if (!advance_replica(e->tick, deadline, stop_requested)) return out_of_time();
    const std::string error = replica_->apply(*e);
    if (!error.empty()) out.lost.push_back(error);
    ++out.replayed;
  }
  // Strokes the replay made or swapped go into the next snapshot.
  if (!advance_replica(target, deadline, stop_requested)) return out_of_time();
  return {};
}

std::optional<Recovered> Keeper::recover(const std::function<bool()>& stop_requested) {
  const auto began = Clock::now();
  Recovered out;
  auto forget = [this] {
    replica_.reset();
    history_.restore({}, 1, 0);
    stroke_keys_.clear();
    bundle_key_.clear();
    bundle_stored_ = false;
  };
  refused_bundles_.clear();
  store::Recovery rec = store_.recover([&](const store::StoredSnapshot& snap) -> std::string {
    if (stop_requested && stop_requested()) throw RecoveryStopped("recovery stopped before it replayed anything");
    try {
      out = Recovered{};
      use_snapshot(snap, out);
      return {};
    } catch (const RecoveryStopped&) {
      forget();
      throw;
    } catch (const std::exception& e) {  // the snapshot does not fit: the one before it is tried
      forget();
      return e.what();
    }
  });
  std::vector<std::string> lost = std::move(rec.lost);
  if (!rec.snapshot) {
    if (!rec.journal.empty() || !lost.empty()) {
      for (const auto& l : lost) log::warning("recovery: {}", l);
      log::warning("recovery: {} has no usable snapshot; starting anew", store_.database().string());
    }
    return std::nullopt;
  }
  out.lost = std::move(lost);
  try {
    const std::string stopped = replay(rec.journal, stop_requested, out);
    if (!stopped.empty()) {
      out.lost.push_back(stopped);
      // What comes after the recovered tick cannot be replayed: left in the
      // journal it would be replayed after the next snapshot, on a sculpt
      // that went on without it.
      const std::uint64_t dropped = store_.drop_journal_after(replica_->next_tick());
      if (dropped > 0)
        out.lost.push_back(fmt::format("the journal after tick {} ({} record{}) was dropped from the store",
                                       replica_->next_tick() > 0 ? replica_->next_tick() - 1 : 0, dropped,
                                       dropped == 1 ? "" : "s"));
    }
  } catch (const RecoveryStopped&) {
    forget();
    throw;
  } catch (const std::exception& e) {
    log::warning("recovery: {}: {}; starting anew", store_.database().string(), e.what());
    forget();
    return std::nullopt;
  }
  out.state = replica_->state();
  out.first_tick = replica_->first_tick();
  out.next_tick = replica_->next_tick();
  out.paused = replica_->paused();
  out.hash = replica_->world().hash();
  publish_history();
  out.seconds = std::chrono::duration<double>(Clock::now() - began).count();
  return out;
}

}  // namespace sculpt::daemon
