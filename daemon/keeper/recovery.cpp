// Keeper: recovery from the store's snapshots and journal (written by
// snapshots.cpp and the journal thread), and --open of a .sculpt file.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <stdexcept>

#include <fmt/chrono.h>
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
  r.value(s.number, "stroke"), r.value(s.scene, "stroke"), r.value(s.body, "stroke"), r.value(s.summary, "stroke");
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
std::deque<Stroke> Keeper::read_strokes(store::Store& store, const store::StoredSnapshot& snap, const nlohmann::json& keys,
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
    const auto bytes = store.read_blob(key, room + kStrokeOverhead, why);
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
    if (s.summary.first_tick > s.summary.last_tick || s.summary.last_tick > kMaxTick)
      refuse(fmt::format("stroke {}: ticks {} to {}", s.number, s.summary.first_tick, s.summary.last_tick));
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
void Keeper::use_snapshot(store::Store& store, const store::StoredSnapshot& snap, Recovered& out) {
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
      const auto bytes = store.read_blob(bundle_key, kMaxBundleBytes, why);
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
    const auto state = store.read_state(snap, expected, why);
    if (!state) refuse(why);
    replica_->restore_state(*state);
    if (replica_->first_tick() != first_tick || replica_->next_tick() != next_tick || replica_->paused() != paused)
      refuse(fmt::format("its state is of tick {} from tick {}{}, its meta says tick {} from tick {}{}",
                         replica_->next_tick(), replica_->first_tick(), replica_->paused() ? " (paused)" : "",
                         next_tick, first_tick, paused ? " (paused)" : ""));
  }
  std::uint64_t older = 0;
  std::deque<Stroke> strokes = read_strokes(store, snap, meta_at(meta, "strokes"), next_stroke, older);
  for (const Stroke& s : strokes) {
    if (s.scene == number) check_stroke(s, replica_->world(), scene);
    else if (s.scene == 0 || s.scene > number) refuse(fmt::format("stroke {} is of scene {}", s.number, s.scene));
  }
  out.strokes = strokes.size();
  history_.restore(std::move(strokes), next_stroke, dropped + older);
  next_scene_ = next_scene;
  bundle_key_ = bundle_key;
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
    if (e->kind == JournalEntry::Kind::scene && e->number == number) continue;  // the snapshot's own scene start
    if (e->kind == JournalEntry::Kind::scene)
      return fmt::format("the scene loaded at tick {} was not saved before the daemon ended: the sculpt is "
                         "recovered as it was before that load", e->tick);
    // A mark, a message or a history move of tick t: the sim thread ran t. A pause
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
  std::vector<std::string> why;
  std::optional<Recovered> rec = recover_store(store_, stop_requested, why, /*own=*/true);
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

Recovered Keeper::open_file(const std::filesystem::path& file, const std::function<bool()>& stop_requested) {
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
  std::optional<Recovered> rec = recover_store(*candidate, stop_requested, why, /*own=*/false);
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
// marker of the run that ended speaks of. Everything read is checked
// (use_snapshot, replay); RecoveryStopped goes to the caller.
std::optional<Recovered> Keeper::recover_store(store::Store& store, const std::function<bool()>& stop_requested,
                                               std::vector<std::string>& why, bool own) {
  const auto began = Clock::now();
  Recovered out;
  std::unordered_set<std::string> held;  // the blobs the snapshot used refers to: the store holds them
  refused_bundles_.clear();
  store::Recovery rec = store.recover([&](const store::StoredSnapshot& snap) -> std::string {
    if (stop_requested && stop_requested()) throw RecoveryStopped("recovery stopped before it replayed anything");
    try {
      out = Recovered{};
      use_snapshot(store, snap, out);
      held.clear();
      for (const auto& [key, size] : snap.blobs) held.insert(key);
      return {};
    } catch (const RecoveryStopped&) {
      reset_history();
      throw;
    } catch (const std::exception& e) {  // the snapshot does not fit: the one before it is tried
      reset_history();
      return e.what();
    }
  });
  if (!rec.snapshot) {
    if (!rec.journal.empty() || !rec.lost.empty()) {
      why = std::move(rec.lost);
      why.push_back(fmt::format("{} has no usable snapshot", store.database().string()));
    }
    return std::nullopt;
  }
  out.lost = std::move(rec.lost);
  std::string stopped;
  try {
    stopped = replay(rec.journal, stop_requested, out);
  } catch (const RecoveryStopped&) {
    reset_history();
    throw;
  } catch (const std::exception& e) {
    why = std::move(out.lost);
    why.push_back(fmt::format("{}: {}", store.database().string(), e.what()));
    reset_history();
    return std::nullopt;
  }
  out.state = replica_->state();
  out.first_tick = replica_->first_tick();
  out.next_tick = replica_->next_tick();
  out.paused = replica_->paused();
  out.hash = replica_->world().hash();
  publish_history();
  confirmed_keys_ = std::move(held);
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
    const double span_ticks = static_cast<double>(settings_.replay_span_limit.count()) * replica_->rate();
    if (journal_end > out.next_tick && static_cast<double>(journal_end - out.next_tick) <= span_ticks) {
      const double s = seconds_of(journal_end - out.next_tick);
      lost_s += s;
      out.lost.push_back(fmt::format("{}; the journal after it, to tick {}, is lost ({:.1f} s of sculpt)", stopped,
                                     journal_end - 1, s));
    } else if (journal_end > out.next_tick) {  // a record no sculpt could have made: no seconds to count
      out.lost.push_back(fmt::format("{}; the journal after it is not replayed", stopped));
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

}  // namespace sculpt::daemon
