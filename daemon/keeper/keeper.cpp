#include "keeper/keeper.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

#include <fmt/format.h>

#include "keeper/journal_codec.hpp"
#include "keeper/keeper_jobs.hpp"
#include "log/log.hpp"

namespace sculpt::daemon {
namespace {

using Clock = std::chrono::steady_clock;
constexpr auto kIdleWait = std::chrono::milliseconds(10);
constexpr auto kReplaySlice = std::chrono::milliseconds(20);  // between journal commits
constexpr unsigned kChunkBits = 10;  // what `history` shows, in chunks of 1024 stroke numbers
// A store with nothing to write looks at its files this often (taken away
// while the sculpt is paused, a second daemon could otherwise take the directory).
constexpr auto kIdleCheck = std::chrono::seconds(1);

std::int64_t wall_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

// An undo or redo between its planning and the sim thread's writing it.
struct Keeper::InFlight {
  std::unique_ptr<Request> request;
  struct Sent {
    std::vector<std::uint32_t> blocks;
    std::vector<std::byte> images;  // the sim thread's copy (it may scribble on it)
    EditImages message;
  };
  std::deque<Sent> sent;  // a deque: the sim thread holds pointers into it
  std::size_t queued = 0, applied = 0;
  bool closing = false;   // sent: the mark that closes the open strokes (id 0); the plan follows
  EditResult result;
};

// What `history` pages through: the strokes in chunks shared with the
// replica thread, each rebuilt only when one of its strokes changed.
struct Keeper::HistoryView {
  std::vector<std::shared_ptr<const std::vector<StrokeInfo>>> chunks;  // in stroke order
  std::vector<std::uint64_t> starts;  // the index of each chunk's first stroke
  std::uint64_t total = 0, budget = 0, used = 0, dropped = 0;
  std::uint32_t scene = 0;
};

Keeper::Keeper(KeeperSettings settings, JournalTap& tap)
    : settings_(std::move(settings)),
      tap_(tap),
      store_(store::Store::open(settings_.dir, settings_.limits)),
      previous_run_(SaveMarker::read(settings_.dir)),
      marker_(settings_.dir),
      history_(settings_.history_budget, settings_.max_strokes) {
  saved_.pid = ::getpid();
}

Keeper::~Keeper() { stop(); }

void Keeper::scene_started(std::shared_ptr<const SceneBundle> bundle, std::shared_ptr<const scene::Scene> scene,
                           std::uint64_t first_tick, bool recovered) {
  JournalEntry e;
  {
    std::lock_guard lock(mutex_);
    if (recovered) {
      tap_.scene.store(replica_->scene_number(), std::memory_order_relaxed);
      next_snapshot_ = {};  // at once: the store's newest snapshot is the recovered point
      return;
    }
    e.kind = JournalEntry::Kind::scene;
    e.tick = first_tick;
    e.edit = next_scene_++;
    incoming_[e.edit] = Incoming{std::move(bundle), std::move(scene), first_tick};
  }
  tap_.scene.store(e.edit, std::memory_order_relaxed);
  // No sim thread runs: the io thread is the producer now. A full ring (a
  // journal thread held up by the disk) is waited out, for a while: the
  // entry marks where the old scene's input ends.
  for (int waited_ms = 0; !tap_.record(e); ++waited_ms) {
    if (waited_ms == 5000) {
      log::err("autosave: the journal stayed full for 5 s; the sculpt of the new scene is not saved");
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void Keeper::start_anew() {
  const store::Kept kind = unrecovered_ ? store::Kept::unrecovered : store::Kept::previous;
  const std::filesystem::path kept = store_.set_aside(kind);
  if (!kept.empty() && kind == store::Kept::previous)
    log::notice("autosave: the sculpt saved before is kept as {} (sculptd --open {} goes back to it)", kept.string(),
                kept.string());
  else if (!kept.empty())
    log::warning("autosave: the store that could not be recovered is kept as {}, as it was", kept.string());
  unrecovered_ = false;
  reset_history();
  std::lock_guard lock(mutex_);
  next_scene_ = 1;
}

void Keeper::reset_history() {
  replica_.reset();
  history_.restore({}, 1, 0);
  stroke_keys_.clear();
  unsaved_.clear();
  bundle_key_.clear();
  confirmed_keys_.clear();
  history_chunks_.clear();
  std::lock_guard lock(mutex_);
  written_snapshots_.clear();
  shown_.reset();
}

void Keeper::start() {
  if (journal_thread_.joinable()) return;
  saved_.ran = saved_.committed = collected_;
  marker_.write(saved_);  // this run's, from now on
  journal_thread_ = std::thread([this] { run_journal(); });
  pthread_setname_np(journal_thread_.native_handle(), "sculptd-journal");
  store_thread_ = std::thread([this] { run_store(); });
  pthread_setname_np(store_thread_.native_handle(), "sculptd-store");
  replica_thread_ = std::thread([this] { run_replica(); });
  pthread_setname_np(replica_thread_.native_handle(), "sculptd-replica");
}

void Keeper::stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  store_wake_.notify_all();
  if (journal_thread_.joinable()) journal_thread_.join();
  if (replica_thread_.joinable()) replica_thread_.join();
  if (store_thread_.joinable()) store_thread_.join();
}

// --- the journal thread -------------------------------------------------------------

void Keeper::run_journal() {
  for (;;) {
    bool stopping = false;
    std::uint64_t asked = 0;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, kIdleWait,
                     [this] { return stop_ || collect_asked_ > collect_done_ || !exports_.empty(); });
      stopping = stop_;
      asked = collect_asked_;
    }
    collect();
    std::deque<std::unique_ptr<Request>> exports;
    {
      std::lock_guard lock(mutex_);
      collect_done_ = asked;
      exports.swap(exports_);
    }
    wake_.notify_all();
    // The sim thread has stopped by the time stop() is called: all it did is taken now.
    if (stopping || !exports.empty() || Clock::now() >= next_commit_) seal();
    // An export is the store as it is once the journal so far is in it: its
    // newest snapshot and the journal after it, which opening the file
    // replays (at most replay_work_per_snapshot of work). Nothing of it
    // runs on the replica, so an export neither waits for the replica nor
    // adds its work to the machine's.
    for (auto& r : exports) {
      auto job = std::make_unique<Job>();
      job->kind = Job::Kind::export_file;
      job->request = std::move(r);
      queue_job(std::move(job));
    }
    if (stopping) break;
  }
  std::lock_guard lock(mutex_);
  journal_done_ = true;
  for (auto& r : exports_) r->done(ExportResult{"the daemon is stopping", -1, 0});
  exports_.clear();
  wake_.notify_all();
  store_wake_.notify_all();
}

// Takes what the sim thread recorded: into the next commit, and on to the
// replica thread.
void Keeper::collect() {
  const std::uint64_t finished = tap_.finished();  // first: every entry of a tick before it is in the ring
  std::vector<JournalEntry> taken;
  while (const JournalEntry* e = tap_.entries().peek()) {
    if (e->kind == JournalEntry::Kind::scene) {
      // The old scene's entries, then the new one's start: a recovery never
      // depends on the replica thread having got this far.
      seal();
      auto job = std::make_unique<Job>();
      job->kind = Job::Kind::scene_start;
      job->scene = *e;
      {
        std::lock_guard lock(mutex_);
        if (const auto it = incoming_.find(e->edit); it != incoming_.end()) job->bundle = it->second.bundle;
        job->next_scene = next_scene_;
      }
      if (job->bundle) queue_job(std::move(job));
    }
    encode_entry(*e, batch_bytes_);
    batch_.emplace_back(e->tick + 1, batch_bytes_.size());  // store ticks are global ticks + 1 (a snapshot of none is 0)
    taken.push_back(*e);
    tap_.entries().pop();
  }
  collected_ = std::max(collected_, finished);
  std::lock_guard lock(mutex_);
  to_replica_.insert(to_replica_.end(), taken.begin(), taken.end());
  finished_shared_ = collected_;
  if (!taken.empty()) wake_.notify_all();
}

// What was collected since the last seal, with a mark of the last tick
// finished, for the store thread.
void Keeper::seal() {
  next_commit_ = Clock::now() + settings_.commit_every;
  const bool marking = collected_ > marked_;
  if (marking) {
    JournalEntry mark;
    mark.kind = JournalEntry::Kind::reached;
    mark.tick = collected_ - 1;
    mark.wall_ns = wall_ns();
    encode_entry(mark, batch_bytes_);
    batch_.emplace_back(collected_, batch_bytes_.size());
  }
  if (batch_.empty()) return;
  auto job = std::make_unique<Job>();
  job->kind = Job::Kind::journal;
  job->bytes = std::exchange(batch_bytes_, {});
  job->records = std::exchange(batch_, {});
  job->mark = marking ? collected_ : 0;
  job->ran = collected_;
  marked_ = collected_;
  queue_job(std::move(job));
}

// Any thread. The journal waiting for a stalled disk is bounded: past
// max_pending_bytes its oldest batches are dropped (the store records the
// gap); an unwritten periodic snapshot is superseded by a newer one.
void Keeper::queue_job(std::unique_ptr<Job> job) {
  {
    std::lock_guard lock(mutex_);
    if (job->kind == Job::Kind::journal) {
      queued_journal_bytes_ += job->bytes.size();
      while (queued_journal_bytes_ > settings_.limits.max_pending_bytes) {
        const auto oldest = std::find_if(jobs_.begin(), jobs_.end(), [](const auto& j) { return j->kind == Job::Kind::journal; });
        if (oldest == jobs_.end()) break;
        const Job& j = **oldest;
        if (!j.records.empty()) {
          const std::uint64_t first = j.records.front().first, last = j.records.back().first;
          if (dropped_.records == 0) dropped_.first = first;
          dropped_.first = std::min(dropped_.first, first);
          dropped_.last = std::max(dropped_.last, last);
          dropped_.records += j.records.size();
        }
        queued_journal_bytes_ -= j.bytes.size();
        jobs_.erase(oldest);
      }
    } else if (job->kind == Job::Kind::snapshot) {
      // Those after the last export (which must hold its own) are older than this one.
      auto keep_until = jobs_.begin();
      for (auto it = jobs_.begin(); it != jobs_.end(); ++it)
        if ((*it)->kind == Job::Kind::export_file) keep_until = std::next(it);
      jobs_.erase(std::remove_if(keep_until, jobs_.end(), [](const auto& j) { return j->kind == Job::Kind::snapshot; }),
                  jobs_.end());
    }
    jobs_.push_back(std::move(job));
  }
  store_wake_.notify_one();
}

// --- the store thread -----------------------------------------------------------------

void Keeper::run_store() {
  for (;;) {
    std::vector<std::unique_ptr<Job>> batches;
    std::unique_ptr<Job> job;
    Dropped dropped;
    bool retry = false;
    {
      std::unique_lock lock(mutex_);
      // A store holding unwritten records retries without new input too (a
      // paused sculpt); one with nothing to write still looks at its files.
      const bool waiting = health_.pending_records > 0 || health_.degraded;
      const auto ready = [this] { return !jobs_.empty() || (journal_done_ && replica_done_); };
      const bool idle = !store_wake_.wait_for(lock, waiting ? settings_.limits.retry_interval : kIdleCheck, ready);
      retry = idle && waiting;
      if (idle && !waiting) {
        lock.unlock();
        const store::Status st = store_.check_files();
        store_written(st, "a look at its files");
        continue;
      }
      if (jobs_.empty() && !retry) break;  // everything written, and nothing more will come
      while (!jobs_.empty() && jobs_.front()->kind == Job::Kind::journal) {
        queued_journal_bytes_ -= jobs_.front()->bytes.size();
        batches.push_back(std::move(jobs_.front()));
        jobs_.pop_front();
      }
      if (batches.empty() && !jobs_.empty()) {
        job = std::move(jobs_.front());
        jobs_.pop_front();
      }
      dropped = std::exchange(dropped_, {});
    }
    if (dropped.records > 0) store_.record_dropped(dropped.first, dropped.last, dropped.records);
    if (!batches.empty() || retry) write_batches(batches);
    else if (job && job->kind == Job::Kind::scene_start) write_scene_start(*job);
    else if (job && job->kind == Job::Kind::snapshot) write_snapshot(*job);
    else if (job && job->kind == Job::Kind::export_file) write_export(*job);
  }
  const store::Health h = store_.health();
  if (h.pending_records == 0 && !h.degraded && !h.unnamed) {
    marker_.remove();  // everything saved (a gap is the store's to tell): nothing for the next start to tell
  } else {
    saved_.ended = true;
    marker_.write(saved_);
    log::warning("autosave: the daemon ends with {} journal records of {:.1f} s of sculpt not written to {} ({})",
                 h.pending_records, seconds_of(saved_.ran - saved_.committed), store_.database().string(),
                 h.last_error.empty() ? h.relocation : h.last_error);
  }
}

void Keeper::write_batches(std::vector<std::unique_ptr<Job>>& batches) {
  std::vector<store::RecordView> records;
  std::uint64_t bytes = 0;
  for (const auto& j : batches) {
    std::size_t begin = 0;
    for (const auto& [tick, end] : j->records) {
      records.push_back({tick, std::span<const std::byte>(j->bytes).subspan(begin, end - begin)});
      begin = end;
    }
    bytes += j->bytes.size();
    if (j->mark) unconfirmed_mark_ = std::max(unconfirmed_mark_, j->mark);
    saved_.ran = std::max(saved_.ran, j->ran);
  }
  const auto now = Clock::now();
  const store::Status st = store_.append(records);  // a failed one is kept by the store and retried
  {
    std::lock_guard lock(mutex_);
    stats_.entries += records.size();
    stats_.journal_bytes += bytes;
    ++stats_.commits;
    if (last_commit_ != Clock::time_point{})
      stats_.longest_commit_gap_ms =
          std::max(stats_.longest_commit_gap_ms, std::chrono::duration<double, std::milli>(now - last_commit_).count());
  }
  last_commit_ = now;
  store_written(st, "journal");
}

double Keeper::seconds_of(std::uint64_t ticks) const {
  std::lock_guard lock(mutex_);
  return static_cast<double>(ticks) / rate_hz_;
}

// After a write: the commit counted, the failure logged once, the files
// written back said, the marker brought up to date.
void Keeper::store_written(const store::Status& st, const char* what) {
  const store::Health health = store_.health();
  if (st.ok && health.pending_records == 0) saved_.committed = std::max(saved_.committed, unconfirmed_mark_);
  if (!st.ok && !st.deferred && saved_.failing_since_ns == 0) saved_.failing_since_ns = wall_ns();
  if (st.ok && health.pending_records == 0) saved_.failing_since_ns = 0;
  if (!st.ok && !st.deferred) saved_.error = st.error;
  if (st.ok) saved_.error.clear();
  saved_.unnamed = health.unnamed;
  marker_.write(saved_);
  std::lock_guard lock(mutex_);
  if (!st.ok && !st.deferred && st.error != last_store_error_)
    log::warning("autosave: {} ({}); the sculpt goes on in memory and the store is retried", st.error, what);
  if (st.ok && !last_store_error_.empty() && health_.degraded) log::notice("autosave: the store works again");
  if (!st.deferred) last_store_error_ = st.ok ? std::string() : st.error;
  if (health.relocations > relocations_seen_) {
    relocations_seen_ = health.relocations;
    log::warning("autosave: {}", health.relocation);
    snapshot_soon_ = true;  // a fresh one in the files as they are now
  }
  health_ = health;
}

// --- the replica thread ---------------------------------------------------------------

// SCHED_IDLE while the replica keeps up: it costs what the real-time world
// costs, and must not take a CPU the sim, io or haptics thread wants. A
// replica more than a second behind, or one an undo or export waits on,
// runs at normal priority until it has caught up: a machine kept busy by
// others must not starve it (and the history with it) for good.
void Keeper::set_background(bool background) {
  if (background == background_) return;
  sched_param none{};
  pthread_setschedparam(pthread_self(), background ? SCHED_IDLE : SCHED_OTHER, &none);
  background_ = background;
}

void Keeper::run_replica() {
  for (;;) {
    std::unique_ptr<Request> request;
    const bool stopping = take_entries(request);
    const double behind_s = replica_ && finished_ > replica_->next_tick()
                                ? static_cast<double>(finished_ - replica_->next_tick()) / replica_->rate()
                                : 0.0;
    set_background(behind_s < 1.0);
    const bool caught_up = replay_some(Clock::now() + kReplaySlice);
    if (request) serve(std::move(request));
    if (in_flight_) send_edits();
    {
      std::lock_guard lock(mutex_);
      if (std::exchange(snapshot_soon_, false)) next_snapshot_ = {};
    }
    if (caught_up && (Clock::now() >= next_snapshot_ || replayed_since_snapshot_ >= settings_.replay_work_per_snapshot))
      snapshot("periodic");
    if (stopping) break;
  }
  // The end: at normal priority, everything replayed, a last snapshot.
  set_background(false);
  replay_all();
  if (replica_) snapshot("at exit");
  finish_requests();
  std::lock_guard lock(mutex_);
  replica_done_ = true;
  store_wake_.notify_all();
}

// Moves the journal thread's entries here; a request to serve when none is
// in flight. True once the journal thread is done and everything is here.
bool Keeper::take_entries(std::unique_ptr<Request>& request) {
  std::unique_lock lock(mutex_);
  // Behind: no rest before the next slice.
  const bool behind = replica_ && replica_->next_tick() < finished_shared_;
  wake_.wait_for(lock, behind ? std::chrono::milliseconds(0) : kIdleWait, [this] {
    return journal_done_ || !to_replica_.empty() || (!requests_.empty() && !in_flight_);
  });
  inbox_.insert(inbox_.end(), to_replica_.begin(), to_replica_.end());
  to_replica_.clear();
  finished_ = finished_shared_;
  if (!in_flight_ && !requests_.empty()) {
    request = std::move(requests_.front());
    requests_.pop_front();
  }
  return journal_done_;
}

// Replays what was taken, up to the last finished tick, until `until`;
// true when the replica has caught up.
bool Keeper::replay_some(Clock::time_point until) {
  bool changed = false;
  while (!inbox_.empty()) {
    const JournalEntry e = inbox_.front();
    if (e.kind == JournalEntry::Kind::scene) {
      switch_scene(e.edit);
      inbox_.pop_front();
      changed = true;
      continue;
    }
    // A pause or resume comes before its tick runs: one of the next tick is final.
    const bool before = e.kind == JournalEntry::Kind::pause || e.kind == JournalEntry::Kind::resume;
    if (e.tick > finished_ || (e.tick == finished_ && !before)) break;
    if (!replica_) {  // the scene's replica could not be built: its entries are only journaled
      inbox_.pop_front();
      continue;
    }
    const auto began = Clock::now();
    if (began >= until) return false;
    const std::string error = replica_->apply(e);  // steps the ticks before it first
    replayed_since_snapshot_ += Clock::now() - began;
    if (!error.empty()) log::warning("history: {}", error);
    if (e.kind == JournalEntry::Kind::edit) edit_applied(e);
    changed = true;
    inbox_.pop_front();
  }
  while (replica_ && replica_->next_tick() < finished_) {
    const auto began = Clock::now();
    if (began >= until) break;
    replica_->advance_to(replica_->next_tick() + 1);
    replayed_since_snapshot_ += Clock::now() - began;
    changed = true;
  }
  if (changed) publish_history();
  const bool entries_left = !inbox_.empty() && inbox_.front().tick < finished_ &&
                            inbox_.front().kind != JournalEntry::Kind::scene;
  return !entries_left && (!replica_ || replica_->next_tick() >= finished_);
}

// After the journal thread's last collect: everything, a pause the sim
// thread took as it left (before a tick it never ran) included.
void Keeper::replay_all() {
  std::unique_ptr<Request> none;
  take_entries(none);
  while (!replay_some(Clock::time_point::max())) {
  }
  for (const JournalEntry& e : inbox_) {
    if (e.kind == JournalEntry::Kind::scene) switch_scene(e.edit);
    else if (replica_ && e.tick <= replica_->next_tick()) (void)replica_->apply(e);
  }
  inbox_.clear();
  publish_history();
}

void Keeper::switch_scene(std::uint32_t number) {
  Incoming in;
  {
    std::lock_guard lock(mutex_);
    auto it = incoming_.find(number);
    if (it == incoming_.end()) return;
    in = std::move(it->second);
    incoming_.erase(it);
  }
  try {
    if (replica_) replica_->world().close_edits();
    replica_ = std::make_unique<Replica>(in.bundle, *in.scene, number, in.first_tick, history_);
    std::lock_guard lock(mutex_);
    rate_hz_ = replica_->rate();
  } catch (const std::exception& e) {
    replica_.reset();
    log::err("autosave: cannot build the replica of the new scene ({}); the sculpt is not saved until the next scene",
             e.what());
    return;
  }
  bundle_key_.clear();
  // The journal thread has queued the scene's start; the next periodic
  // snapshot is this replica's first.
}

void Keeper::finish_requests() {
  std::lock_guard lock(mutex_);
  for (auto& r : requests_) {
    if (r->edited) r->done(EditResult{"the daemon is stopping", 0, 0});
    if (r->exported) r->done(ExportResult{"the daemon is stopping", -1, 0});
  }
  requests_.clear();
  if (in_flight_) in_flight_->request->done(EditResult{"the daemon stopped before the edit was applied", 0, 0});
  in_flight_.reset();
}

// Everything the sim thread had done when asked, replayed (an undo plans
// on the newest history, an export holds the sculpt as it is): the journal
// thread takes it from the tap now, the replica replays it.
void Keeper::catch_up() {
  set_background(false);
  {
    std::unique_lock lock(mutex_);
    const std::uint64_t asked = ++collect_asked_;
    wake_.notify_all();
    wake_.wait(lock, [this, asked] { return collect_done_ >= asked || journal_done_; });
    inbox_.insert(inbox_.end(), to_replica_.begin(), to_replica_.end());
    to_replica_.clear();
    finished_ = finished_shared_;
  }
  while (!replay_some(Clock::time_point::max())) {
  }
}

void Keeper::serve(std::unique_ptr<Request> r) {
  catch_up();
  if (!replica_) {
    r->done(EditResult{"the sculpt has no history (its scene could not be replayed)", 0, 0});
    return;
  }
  in_flight_ = std::make_unique<InFlight>();
  in_flight_->request = std::move(r);
  if (history_.open_changes()) {
    // Strokes still open (released, not at rest yet) are closed first, at a
    // tick the journal records, so that the plan and any replay agree.
    InFlight::Sent& close = in_flight_->sent.emplace_back();
    close.message.id = 0;
    close.message.scene = replica_->scene_number();
    in_flight_->closing = true;
  } else if (!plan(*in_flight_)) {
    in_flight_.reset();
    return;
  }
  send_edits();
}

// The strokes to swap, their images copied for the sim thread; false (the
// request answered) when there are none.
bool Keeper::plan(InFlight& f) {
  const bool undo = f.request->kind == Request::Kind::undo;
  History::Plan p = undo ? history_.plan_undo(f.request->count, replica_->scene_number())
                         : history_.plan_redo(f.request->count, replica_->scene_number());
  if (p.strokes.empty()) {
    f.request->done(EditResult{p.error, 0, 0});
    return false;
  }
  for (const Stroke* s : p.strokes) {
    InFlight::Sent& sent = f.sent.emplace_back();
    sent.blocks = s->blocks;
    sent.images = s->images;
    sent.message.id = s->number;
    sent.message.scene = s->scene;
    sent.message.body = s->body;
    sent.message.blocks = sent.blocks;
    sent.message.images = sent.images;
  }
  return true;
}

// As many as the sim thread's edit ring takes; the rest at the next turn.
void Keeper::send_edits() {
  InFlight& f = *in_flight_;
  while (f.queued < f.sent.size() && tap_.send_edit(&f.sent[f.queued].message)) ++f.queued;
}

// The sim thread wrote (or refused) stroke images; the replica has swapped
// them too (Replica::apply).
void Keeper::edit_applied(const JournalEntry& e) {
  if (!in_flight_) return;  // a recovered journal's edit
  InFlight& f = *in_flight_;
  if (f.closing) {
    // The open strokes are closed now: plan on the whole history.
    f.closing = false;
    f.sent.clear();
    f.queued = f.applied = 0;
    if (e.refused || !replica_) f.request->done(EditResult{"the scene was swapped before the edit was applied", 0, 0});
    else if (plan(f)) return send_edits();
    in_flight_.reset();
    return;
  }
  if (e.refused && f.result.error.empty())
    f.result.error = fmt::format("stroke {} was not applied: the scene was swapped first", e.edit);
  if (!e.refused) ++f.result.done;
  f.result.tick = e.tick;
  if (++f.applied < f.sent.size()) return;
  publish_history();  // what `history` shows agrees with the answer
  f.request->done(EditResult(f.result));
  in_flight_.reset();
}

void Keeper::publish_history() {
  bool all = false;
  const std::vector<std::uint32_t> touched = history_.take_touched(all);
  const std::deque<Stroke>& strokes = history_.strokes();
  std::set<std::uint32_t> chunks;
  if (all) {
    history_chunks_.clear();
    for (const Stroke& s : strokes) chunks.insert(s.number >> kChunkBits);
  } else {
    for (std::uint32_t n : touched) chunks.insert(n >> kChunkBits);
  }
  for (std::uint32_t c : chunks) {
    // Numbers grow along the deque: the chunk's strokes are one run of it.
    const auto by_number = [](const Stroke& s, std::uint32_t n) { return s.number < n; };
    const auto first = std::lower_bound(strokes.begin(), strokes.end(), c << kChunkBits, by_number);
    const auto last = std::lower_bound(first, strokes.end(), (c + 1) << kChunkBits, by_number);
    if (first == last) {
      history_chunks_.erase(c);
      continue;
    }
    auto infos = std::make_shared<std::vector<StrokeInfo>>();
    infos->reserve(static_cast<std::size_t>(last - first));
    for (auto it = first; it != last; ++it)
      infos->push_back({it->number, it->body, it->scene, it->mesh, it->edit.tools, it->edit.first_tick,
                        it->edit.release_tick ? it->edit.release_tick : it->edit.last_tick, it->vertices, it->bytes(),
                        it->undone});
    history_chunks_[c] = std::move(infos);
  }
  auto view = std::make_shared<HistoryView>();
  for (const auto& [c, infos] : history_chunks_) {
    (void)c;
    view->starts.push_back(view->total);
    view->total += infos->size();
    view->chunks.push_back(infos);
  }
  view->budget = history_.budget();
  view->used = history_.used();
  view->dropped = history_.dropped();
  view->scene = replica_ ? replica_->scene_number() : 0;
  std::lock_guard lock(mutex_);
  stats_.replica_behind = replica_ && finished_ > replica_->next_tick() ? finished_ - replica_->next_tick() : 0;
  shown_ = std::move(view);
}

void Keeper::write_export(Job& job) {
  // Beside the store; where the disk refuses it (read-only, full), in memory:
  // an export is how a sculpt the disk will not take is saved elsewhere.
  const std::string name = fmt::format("export-{}.sculpt", ::getpid());
  std::filesystem::path file = settings_.dir / name;
  std::error_code ec;
  std::filesystem::remove(file, ec);
  try {
    store_.export_copy(file);
  } catch (const store::StoreError& e) {
    std::filesystem::remove(file, ec);
    file = runtime_dir() / name;
    std::filesystem::remove(file, ec);
    try {
      store_.export_copy(file);
    } catch (const store::StoreError& again) {
      std::filesystem::remove(file, ec);
      job.request->done(ExportResult{fmt::format("{}; and in memory: {}", e.what(), again.what()), -1, 0});
      return;
    }
  }
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  std::filesystem::remove(file, ec);  // the fd is the only way to it now
  if (fd < 0) {
    job.request->done(
        ExportResult{fmt::format("{}: cannot open the copy: {}", file.string(), std::strerror(errno)), -1, 0});
    return;
  }
  const off_t size = ::lseek(fd, 0, SEEK_END);
  job.request->done(ExportResult{{}, fd, static_cast<std::uint64_t>(size < 0 ? 0 : size)});
}

template <class Result>
kj::Promise<Result> Keeper::ask(std::unique_ptr<Request> r, std::shared_ptr<Result> out) {
  auto paf = kj::newPromiseAndCrossThreadFulfiller<void>();
  r->fulfiller = kj::mv(paf.fulfiller);
  {
    std::lock_guard lock(mutex_);
    if (!stop_) requests_.push_back(std::move(r));  // else the fulfiller dies with r: the promise is rejected
  }
  wake_.notify_one();
  return paf.promise.then([out] { return kj::mv(*out); });
}

kj::Promise<EditResult> Keeper::edit(bool undo, std::uint32_t count) {
  auto r = std::make_unique<Request>();
  r->kind = undo ? Request::Kind::undo : Request::Kind::redo;
  r->count = count;
  r->edited = std::make_shared<EditResult>();
  auto out = r->edited;
  return ask(std::move(r), std::move(out));
}

kj::Promise<EditResult> Keeper::undo(std::uint32_t count) { return edit(true, count); }
kj::Promise<EditResult> Keeper::redo(std::uint32_t count) { return edit(false, count); }

kj::Promise<ExportResult> Keeper::export_sculpt() {
  auto r = std::make_unique<Request>();
  r->kind = Request::Kind::export_file;
  r->exported = std::make_shared<ExportResult>();
  auto out = r->exported;
  auto paf = kj::newPromiseAndCrossThreadFulfiller<void>();
  r->fulfiller = kj::mv(paf.fulfiller);
  {
    std::lock_guard lock(mutex_);
    if (!stop_) exports_.push_back(std::move(r));  // else the fulfiller dies with r: the promise is rejected
  }
  wake_.notify_all();
  return paf.promise.then([out] { return kj::mv(*out); });
}

HistoryInfo Keeper::history(std::uint32_t from, std::uint32_t limit) const {
  std::shared_ptr<const HistoryView> view;
  {
    std::lock_guard lock(mutex_);
    view = shown_;
  }
  HistoryInfo out;
  if (!view) return out;
  out.budget = view->budget;
  out.used = view->used;
  out.dropped = view->dropped;
  out.scene = view->scene;
  out.total = view->total;
  const std::uint64_t want = limit == 0 ? kMaxHistoryPage : std::min(limit, kMaxHistoryPage);
  // The index of the page's first stroke, then the page.
  std::uint64_t first = 0;
  std::size_t chunk = 0, within = 0;
  if (from == 0) {
    first = view->total > want ? view->total - want : 0;
    chunk = static_cast<std::size_t>(std::upper_bound(view->starts.begin(), view->starts.end(), first) - view->starts.begin());
    chunk = chunk > 0 ? chunk - 1 : 0;
    within = chunk < view->chunks.size() ? static_cast<std::size_t>(first - view->starts[chunk]) : 0;
  } else {
    const auto ends_before = [from](const auto& c) { return c->back().number < from; };
    chunk = static_cast<std::size_t>(std::partition_point(view->chunks.begin(), view->chunks.end(), ends_before) -
                                     view->chunks.begin());
    if (chunk < view->chunks.size()) {
      const auto& c = *view->chunks[chunk];
      within = static_cast<std::size_t>(
          std::lower_bound(c.begin(), c.end(), from, [](const StrokeInfo& s, std::uint32_t n) { return s.number < n; }) -
          c.begin());
      first = view->starts[chunk] + within;
    } else {
      first = view->total;
    }
  }
  for (; chunk < view->chunks.size() && out.strokes.size() < want; ++chunk, within = 0) {
    const auto& c = *view->chunks[chunk];
    for (; within < c.size() && out.strokes.size() < want; ++within) out.strokes.push_back(c[within]);
  }
  out.older = first;
  out.newer = view->total - first - out.strokes.size();
  return out;
}

KeeperStats Keeper::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

store::Health Keeper::health() const {
  std::lock_guard lock(mutex_);
  return health_;
}

}  // namespace sculpt::daemon
