// Keeper: what goes into a snapshot (the replica's state, the scene bundle,
// the strokes, as blobs by content), written by the store thread. Recovery
// from one: recovery.cpp.
#include <algorithm>
#include <chrono>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "keeper/journal_codec.hpp"
#include "keeper/keeper.hpp"
#include "keeper/keeper_jobs.hpp"
#include "log/log.hpp"
#include "sim/state_bytes.hpp"

namespace sculpt::daemon {
using namespace keeper_detail;
namespace {

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
  w.value(s.number), w.value(s.scene), w.value(s.body), w.value(s.summary), w.value(s.vertices);
  w.value(static_cast<std::uint8_t>(s.undone)), w.value(static_cast<std::uint64_t>(s.image_bytes));
  w.array(std::span<const char>(s.mesh.data(), s.mesh.size()));
  w.array(s.blocks), w.array(s.images);
  return out;
}

}  // namespace

// A scene's start as a snapshot of no state: recovery builds the scene's
// world fresh from the bundle at `first_tick` and replays from there. Store thread.
void Keeper::write_scene_start(Job& job) {
  const JournalEntry& e = job.scene;
  const std::vector<std::byte> bytes = job.bundle->bytes();
  const std::string key = blob_key("bundle", bytes);
  const nlohmann::json meta = {{"format", kMetaFormat}, {"fresh", true},          {"scene", e.number},
                               {"next_scene", job.next_scene}, {"scene_file", job.bundle->file}, {"bundle", key},
                               {"first_tick", e.tick},   {"next_tick", e.tick},    {"paused", false},
                               {"next_stroke", 1},       {"dropped", 0},           {"strokes", nlohmann::json::array()}};
  const std::vector<store::BlobWrite> blobs{{key, bytes}};
  const std::vector<std::string> refs{key};
  store::Status st;
  try {
    check_bundle_size(bytes.size());
    st = store_.write_snapshot(store_.prepare_snapshot(e.tick, {}, meta.dump(), blobs, refs));
  } catch (const std::bad_alloc&) {
    st = store::Status{false, false, "no memory to compress the scene's files"};
  } catch (const std::exception& x) {  // more than a store holds
    st = store::Status{false, false, x.what()};
  }
  // Snapshots of the scenes before it are obsolete now, even when this one
  // failed: the journal holds the swap, which a replay cannot cross.
  scene_started_ = std::max(scene_started_, e.number);
  store_written(st, "the start of a scene");
}

// Replica thread: the replica's state, compressed here (never holding up
// the store), for the store thread.
void Keeper::snapshot(const char* why) {
  if (!replica_) return;
  next_snapshot_ = Clock::now() + settings_.snapshot_every;
  replayed_since_snapshot_ = {};
  {
    std::vector<std::pair<std::uint64_t, std::vector<std::string>>> written;
    {
      std::lock_guard lock(mutex_);
      written.swap(written_snapshots_);
    }
    // The newest snapshot written holds the blobs it refers to: others need not carry them.
    if (!written.empty()) confirmed_keys_ = {written.back().second.begin(), written.back().second.end()};
  }
  const auto began = Clock::now();
  const std::vector<std::byte> state = replica_->state();
  std::vector<std::vector<std::byte>> owned;
  owned.reserve(history_.strokes().size() + 1);  // BlobWrite points into these
  std::vector<store::BlobWrite> blobs;
  std::vector<std::string> refs;
  if (bundle_key_.empty() || !confirmed_keys_.count(bundle_key_)) {
    owned.push_back(replica_->bundle()->bytes());
    bundle_key_ = blob_key("bundle", owned.back());
    if (!confirmed_keys_.count(bundle_key_)) blobs.push_back({bundle_key_, owned.back()});
  }
  refs.push_back(bundle_key_);
  for (std::uint32_t n : history_.take_gone()) stroke_keys_.erase(n), unsaved_.erase(n);
  for (std::uint32_t n : history_.take_changed()) unsaved_.insert(n);
  std::map<std::uint32_t, std::string> keys;  // this snapshot's
  nlohmann::json strokes = nlohmann::json::array();
  for (const Stroke& s : history_.strokes()) {
    auto known = stroke_keys_.find(s.number);
    std::string key;
    bool have_bytes = false;
    if (known == stroke_keys_.end() || unsaved_.count(s.number)) {
      owned.push_back(stroke_bytes(s));
      key = blob_key("stroke", owned.back());
      have_bytes = true;
    } else {
      key = known->second;
    }
    if (!confirmed_keys_.count(key)) {
      if (!have_bytes) owned.push_back(stroke_bytes(s));
      blobs.push_back({key, owned.back()});
    }
    refs.push_back(key);
    strokes.push_back(key);
    keys[s.number] = std::move(key);
  }
  stroke_keys_ = std::move(keys);
  unsaved_.clear();
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
  auto job = std::make_unique<Job>();
  job->kind = Job::Kind::snapshot;
  job->scene_number = replica_->scene_number();
  job->sequence = ++snapshot_sequence_;
  job->state_bytes = state.size();
  job->why = why;
  try {
    for (const store::BlobWrite& b : blobs)
      if (b.key == bundle_key_) check_bundle_size(b.bytes.size());
    job->prepared = store_.prepare_snapshot(replica_->next_tick(), state, meta.dump(), blobs, refs);
  } catch (const std::bad_alloc&) {
    log::warning("keeper: no memory to compress the snapshot ({}); the next one is tried in {} s", why,
                 std::chrono::duration_cast<std::chrono::seconds>(settings_.snapshot_every).count());
    job.reset();
  } catch (const std::exception& e) {  // more than a store holds: no later snapshot fits either
    log::warning("keeper: snapshot ({}): {}; the sculpt goes on in memory", why, e.what());
    job.reset();
  }
  if (job) {
    job->prepare_ms = std::chrono::duration<double, std::milli>(Clock::now() - began).count();
    queue_job(std::move(job));
  }
}

// Store thread.
void Keeper::write_snapshot(Job& job) {
  if (job.scene_number < scene_started_) return;  // a newer scene's start is written: a replay cannot reach this one
  const auto began = Clock::now();
  store::PreparedSnapshot& p = *job.prepared;
  std::uint64_t stored = p.data.size();
  for (const auto& b : p.blobs) stored += b.data.size();
  const store::Status st = store_.write_snapshot(p);
  const double ms = job.prepare_ms + std::chrono::duration<double, std::milli>(Clock::now() - began).count();
  {
    std::lock_guard lock(mutex_);
    ++stats_.snapshots;
    stats_.snapshot_state_bytes = job.state_bytes;
    stats_.snapshot_stored_bytes = stored;
    stats_.snapshot_ms = ms;
    if (st.ok) written_snapshots_.emplace_back(job.sequence, std::move(p.refs));
  }
  if (st.ok)
    log::debug("keeper: snapshot ({}) at tick {}: {} bytes of state, {} new blobs, {:.1f} ms", job.why, p.tick,
               job.state_bytes, p.blobs.size(), ms);
  store_written(st, "snapshot");
}

}  // namespace sculpt::daemon
