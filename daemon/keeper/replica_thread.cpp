#include "keeper/keeper.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <mutex>

#include <fmt/format.h>

#include "keeper/keeper_jobs.hpp"
#include "log/log.hpp"

namespace sculpt::daemon {
using namespace keeper_detail;

namespace {
constexpr auto kReplaySlice = std::chrono::milliseconds(20);  // between journal commits
constexpr unsigned kChunkBits = 10;  // what `history` shows, in chunks of 1024 stroke numbers
}  // namespace

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
    if (in_flight_) send_history_moves();
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
      switch_scene(e.number);
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
    if (e.kind == JournalEntry::Kind::history_move) history_move_applied(e);
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
    if (e.kind == JournalEntry::Kind::scene) switch_scene(e.number);
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
    if (replica_) replica_->world().close_strokes();
    replica_ = std::make_unique<Replica>(in.bundle, *in.scene, number, in.first_tick, history_);
    std::lock_guard lock(mutex_);
    rate_hz_ = replica_->rate();
  } catch (const std::exception& e) {
    replica_.reset();
    log::err("keeper: cannot build the replica of the new scene ({}); the sculpt is not saved until the next scene",
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
    if (r->moved) r->done(HistoryMoveResult{"the daemon is stopping", 0, 0});
    if (r->exported) r->done(ExportResult{"the daemon is stopping", -1, 0});
  }
  requests_.clear();
  if (in_flight_) in_flight_->request->done(HistoryMoveResult{"the daemon stopped before the undo/redo was applied", 0, 0});
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
    r->done(HistoryMoveResult{"the sculpt has no history (its scene could not be replayed)", 0, 0});
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
  send_history_moves();
}

// The strokes to swap, their images copied for the sim thread; false (the
// request answered) when there are none.
bool Keeper::plan(InFlight& f) {
  const bool undo = f.request->kind == Request::Kind::undo;
  History::Plan p = undo ? history_.plan_undo(f.request->count, replica_->scene_number())
                         : history_.plan_redo(f.request->count, replica_->scene_number());
  if (p.strokes.empty()) {
    f.request->done(HistoryMoveResult{p.error, 0, 0});
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

// As many as the sim thread's history-move ring takes; the rest at the next turn.
void Keeper::send_history_moves() {
  InFlight& f = *in_flight_;
  while (f.queued < f.sent.size() && tap_.send_history_move(&f.sent[f.queued].message)) ++f.queued;
}

// The sim thread wrote (or refused) stroke images; the replica has swapped
// them too (Replica::apply).
void Keeper::history_move_applied(const JournalEntry& e) {
  if (!in_flight_) return;  // a recovered journal's history move
  InFlight& f = *in_flight_;
  if (f.closing) {
    // The open strokes are closed now: plan on the whole history.
    f.closing = false;
    f.sent.clear();
    f.queued = f.applied = 0;
    if (e.refused || !replica_) f.request->done(HistoryMoveResult{"the scene was swapped before the undo/redo was applied", 0, 0});
    else if (plan(f)) return send_history_moves();
    in_flight_.reset();
    return;
  }
  if (e.refused && f.result.error.empty())
    f.result.error = fmt::format("stroke {} was not applied: the scene was swapped first", e.number);
  if (!e.refused) ++f.result.done;
  f.result.tick = e.tick;
  if (++f.applied < f.sent.size()) return;
  publish_history();  // what `history` shows agrees with the answer
  f.request->done(HistoryMoveResult(f.result));
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
      infos->push_back({it->number, it->body, it->scene, it->mesh, it->summary.tools, it->summary.first_tick,
                        it->summary.release_tick ? it->summary.release_tick : it->summary.last_tick, it->vertices, it->bytes(),
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

}  // namespace sculpt::daemon
