// Keeper: what goes into a snapshot (the replica's state, the scene bundle,
// the strokes, as blobs by content) and recovery from it.
#include <chrono>
#include <ctime>

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "main/journal_codec.hpp"
#include "main/keeper.hpp"
#include "main/keeper_jobs.hpp"
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
// world fresh from the bundle at `first_tick` and replays from there. Store thread.
void Keeper::write_scene_start(Job& job) {
  const JournalEntry& e = job.scene;
  const std::vector<std::byte> bytes = job.bundle->bytes();
  const std::string key = blob_key("bundle", bytes);
  const nlohmann::json meta = {{"format", kMetaFormat}, {"fresh", true},          {"scene", e.edit},
                               {"next_scene", job.next_scene}, {"scene_file", job.bundle->file}, {"bundle", key},
                               {"first_tick", e.tick},   {"next_tick", e.tick},    {"paused", false},
                               {"next_stroke", 1},       {"dropped", 0},           {"strokes", nlohmann::json::array()}};
  const std::vector<store::BlobWrite> blobs{{key, bytes}};
  const std::vector<std::string> refs{key};
  store::Status st;
  try {
    st = store_.write_snapshot(store_.prepare_snapshot(e.tick, {}, meta.dump(), blobs, refs));
  } catch (const std::bad_alloc&) {
    st = store::Status{false, false, "no memory to compress the scene's files"};
  }
  // Snapshots of the scenes before it are obsolete now, even when this one
  // failed: the journal holds the swap, which a replay cannot cross.
  scene_started_ = std::max(scene_started_, e.edit);
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
    job->prepared = store_.prepare_snapshot(replica_->next_tick(), state, meta.dump(), blobs, refs);
  } catch (const std::bad_alloc&) {
    log::warning("autosave: no memory to compress the snapshot ({}); the next one is tried in {} s", why,
                 std::chrono::duration_cast<std::chrono::seconds>(settings_.snapshot_every).count());
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
    log::debug("autosave: snapshot ({}) at tick {}: {} bytes of state, {} new blobs, {:.1f} ms", job.why, p.tick,
               job.state_bytes, p.blobs.size(), ms);
  store_written(st, "snapshot");
}

std::optional<Recovered> Keeper::recover() {
  std::vector<std::string> why;
  std::optional<Recovered> rec = recover_store(store_, why, /*own=*/true);
  if (!rec && !why.empty()) {
    for (const auto& l : why) log::warning("recovery: {}", l);
    log::warning("recovery: {} cannot be recovered; starting anew (the store is kept as it is, below)",
                 store_.database().string());
    unrecovered_ = true;
  } else if (!rec && previous_run_ && previous_run_->committed > 0) {
    log::warning("recovery: the daemon before this one (PID {}) had committed the sculpt to tick {}, but {} holds "
                 "none: its files were removed or replaced ({:.1f} s of saved sculpt are missing); starting anew",
                 previous_run_->pid, previous_run_->committed - 1, store_.database().string(),
                 seconds_of(previous_run_->committed));
  }
  if (rec && rec->replay_stopped) restart_store_from(*rec);
  return rec;
}

// After a replay that stopped short: the journal past that point would be
// replayed onto the state the sculpt goes on from, at the next recovery.
// The store as it is is kept (a generation), and a new one starts with a
// snapshot of the state recovered, written before anything runs.
void Keeper::restart_store_from(const Recovered& rec) {
  const std::filesystem::path kept = store_.set_aside(store::Kept::unrecovered);
  if (!kept.empty())
    log::warning("recovery: the store as it was, with the journal it could not replay past tick {}, is kept as {}",
                 rec.next_tick > 0 ? rec.next_tick - 1 : 0, kept.string());
  confirmed_keys_.clear();  // the new store holds no blob yet
  snapshot("recovered");
  std::deque<std::unique_ptr<Job>> jobs;
  {
    std::lock_guard lock(mutex_);
    jobs.swap(jobs_);
  }
  for (auto& job : jobs)
    if (job->kind == Job::Kind::snapshot) write_snapshot(*job);
}

Recovered Keeper::open_file(const std::filesystem::path& file) {
  const std::string unchanged = fmt::format("; nothing was changed ({} is as it was)", store_.database().string());
  // The scratch copy's name means nothing to the user: the file's does.
  const std::string scratch = (store_.dir() / "opening.db").string();
  const auto named = [&](std::string w) {
    for (auto at = w.find(scratch); at != std::string::npos; at = w.find(scratch, at)) w.replace(at, scratch.size(), file.string());
    return w;
  };
  std::optional<store::Store> candidate;
  try {
    candidate.emplace(store_.open_candidate(file));
  } catch (const store::StoreError& e) {
    throw std::runtime_error(fmt::format("--open {}{}", named(e.what()), unchanged));
  }
  std::vector<std::string> why;
  std::optional<Recovered> rec = recover_store(*candidate, why, /*own=*/false);
  if (!rec) {
    reset_history();
    std::string reasons;
    for (const std::string& w : why) reasons += "; " + named(w);
    throw std::runtime_error(fmt::format("--open {}: no sculpt could be recovered from it{}{}", file.string(),
                                         why.empty() ? std::string(" (it holds none)") : reasons, unchanged));
  }
  const std::filesystem::path kept = store_.adopt(std::move(*candidate));
  if (rec->replay_stopped) restart_store_from(*rec);
  if (kept.empty())
    log::notice("opened {}: it is now the sculpt in {}", file.string(), store_.dir().string());
  else
    log::notice("opened {}: it is now the sculpt in {}; the one it replaces is kept as {} (sculptd --open {} goes "
                "back to it)",
                file.string(), store_.dir().string(), kept.string(), kept.string());
  return std::move(*rec);
}

// `store`'s sculpt, or nullopt with what made it unusable in `why` (empty:
// the store holds none). `own`: the store this daemon ran before, which the
// marker of the run that ended speaks of.
std::optional<Recovered> Keeper::recover_store(store::Store& store, std::vector<std::string>& why, bool own) {
  const auto began = Clock::now();
  store::Recovery rec = store.recover();
  Recovered out;
  out.lost = std::move(rec.lost);
  if (!rec.snapshot) {
    if (!rec.journal.empty() || !out.lost.empty()) {
      why = std::move(out.lost);
      why.push_back(fmt::format("{} has no usable snapshot", store.database().string()));
    }
    return std::nullopt;
  }
  std::string stopped;
  try {
    stopped = recover_from(*rec.snapshot, rec.journal, out);
  } catch (const std::exception& e) {
    why = std::move(out.lost);
    why.push_back(fmt::format("{}: {}", store.database().string(), e.what()));
    reset_history();
    return std::nullopt;
  }
  confirmed_keys_.clear();  // the blobs the store holds for the snapshot recovered
  for (const auto& [key, bytes] : rec.snapshot->blobs) confirmed_keys_.insert(key);
  {
    std::lock_guard lock(mutex_);
    rate_hz_ = replica_->rate();
    scene_started_ = replica_->scene_number();
  }
  explain_loss(rec.journal, stopped, own, out);
  out.replay_stopped = !stopped.empty();
  out.seconds = std::chrono::duration<double>(Clock::now() - began).count();
  return out;
}

namespace {
std::string utc_text(std::int64_t wall_ns) {
  const std::time_t secs = static_cast<std::time_t>(wall_ns / 1000000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  return fmt::format("{:%Y-%m-%d %H:%M:%S} UTC", tm);
}
}  // namespace

// What the recovered state lacks, and why: the journal a replay could not
// get through, and what the marker of the run that ended says the store
// never got (its files taken away, or writes refused until it ended).
void Keeper::explain_loss(const std::vector<store::Record>& journal, const std::string& stopped, bool own,
                          Recovered& out) {
  double lost_s = 0;
  // Store ticks are global ticks + 1: a record's is the tick after its own.
  std::uint64_t journal_end = out.next_tick;
  for (const store::Record& r : journal) journal_end = std::max(journal_end, r.tick);
  if (!stopped.empty()) {
    if (journal_end > out.next_tick) {
      const double s = seconds_of(journal_end - out.next_tick);
      lost_s += s;
      out.lost.push_back(fmt::format("{}; the journal after it, to tick {}, is lost ({:.1f} s of sculpt)", stopped,
                                     journal_end - 1, s));
    } else {
      out.lost.push_back(stopped);
    }
  }
  if (own && previous_run_) {
    const SaveState& p = *previous_run_;
    const std::uint64_t held = std::max(journal_end, out.next_tick);
    if (p.committed > held) {
      const double s = seconds_of(p.committed - held);
      lost_s += s;
      out.lost.push_back(fmt::format(
          "the daemon before this one (PID {}) had committed the sculpt to tick {}, but the store holds it only to "
          "tick {}: {:.1f} s of saved sculpt are missing (the store's files were removed or replaced while it ran, "
          "or damaged)",
          p.pid, p.committed - 1, held - 1, s));
    }
    if (p.ran > p.committed && (p.failing_since_ns != 0 || p.unnamed)) {
      const double s = seconds_of(p.ran - p.committed);
      lost_s += s;
      const std::string why =
          p.unnamed ? std::string("the store's files had been removed and could not be written back")
                    : fmt::format("the store could not be written since {} ({})", utc_text(p.failing_since_ns), p.error);
      out.lost.push_back(fmt::format("the daemon before this one (PID {}) {} while {}: ticks {}-{} ({:.1f} s of "
                                     "sculpt, held in its memory) were never saved",
                                     p.pid, p.ended ? "stopped" : "ended", why, p.committed, p.ran - 1, s));
    }
  }
  if (out.lost.empty()) out.loss = "nothing saved was lost";
  else if (lost_s > 0) out.loss = fmt::format("{:.1f} s of sculpt lost, see below", lost_s);
  else out.loss = "not exact, see below";
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
