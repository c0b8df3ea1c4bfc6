#include "main/keeper.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

#include <fmt/format.h>

#include "main/journal_codec.hpp"
#include "main/log.hpp"

namespace sculpt::daemon {
namespace {

using Clock = std::chrono::steady_clock;
constexpr auto kIdleWait = std::chrono::milliseconds(10);
constexpr auto kReplaySlice = std::chrono::milliseconds(20);  // between journal commits

}  // namespace

struct Keeper::Request {
  enum class Kind { undo, redo, export_file };
  Kind kind = Kind::undo;
  std::uint32_t count = 0;
  // The result waits beside a void promise (as in main/worker.hpp): gcc 12
  // warns (-Wmaybe-uninitialized, a false positive) about any value inside
  // kj's cross-thread promise.
  std::shared_ptr<EditResult> edited;
  std::shared_ptr<ExportResult> exported;
  kj::Own<kj::CrossThreadPromiseFulfiller<void>> fulfiller;
  void done(EditResult r) {
    *edited = std::move(r);
    fulfiller->fulfill();
  }
  void done(ExportResult r) {
    *exported = std::move(r);
    fulfiller->fulfill();
  }
};

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

Keeper::Keeper(KeeperSettings settings, JournalTap& tap)
    : settings_(std::move(settings)),
      tap_(tap),
      store_(store::Store::open(settings_.dir, settings_.limits)),
      history_(settings_.history_budget, settings_.max_strokes) {}

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
  if (store_.usage().snapshots > 0) {
    // The sculpt it replaces stays one start away: `sculptd --open previous.db`.
    const std::filesystem::path previous = settings_.dir / "previous.db";
    std::error_code ec;
    std::filesystem::remove(previous, ec);
    store_.export_copy(previous);
    log::notice("autosave: the saved sculpt is kept as {} (start with --open {} to go back to it)", previous.string(),
                previous.string());
  }
  store_.clear();
  replica_.reset();
  history_.restore({}, 1, 0);
  stroke_keys_.clear();
  unsaved_.clear();
  std::lock_guard lock(mutex_);
  next_scene_ = 1;
}

void Keeper::start() {
  if (journal_thread_.joinable()) return;
  journal_thread_ = std::thread([this] { run_journal(); });
  pthread_setname_np(journal_thread_.native_handle(), "sculptd-journal");
  replica_thread_ = std::thread([this] { run_replica(); });
  pthread_setname_np(replica_thread_.native_handle(), "sculptd-replica");
}

void Keeper::stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (journal_thread_.joinable()) journal_thread_.join();
  if (replica_thread_.joinable()) replica_thread_.join();
}

// --- the journal thread -------------------------------------------------------------

void Keeper::run_journal() {
  for (;;) {
    bool stopping = false;
    std::uint64_t asked = 0;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, kIdleWait, [this] { return stop_ || collect_asked_ > collect_done_; });
      stopping = stop_;
      asked = collect_asked_;
    }
    collect();
    {
      std::lock_guard lock(mutex_);
      collect_done_ = asked;
    }
    wake_.notify_all();
    // The sim thread has stopped by the time stop() is called: all it did is taken now.
    if (stopping || Clock::now() >= next_commit_) commit();
    if (stopping) break;
  }
  std::lock_guard lock(mutex_);
  journal_done_ = true;
  wake_.notify_all();
}

// Takes what the sim thread recorded: into the next commit, and on to the
// replica thread.
void Keeper::collect() {
  const std::uint64_t finished = tap_.finished();  // first: every entry of a tick before it is in the ring
  std::vector<JournalEntry> taken;
  while (const JournalEntry* e = tap_.entries().peek()) {
    if (e->kind == JournalEntry::Kind::scene) {
      // The old scene's entries on disk, then the new one's start: a
      // recovery never depends on the replica thread having got this far.
      commit();
      write_scene_start(*e);
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

void Keeper::commit() {
  const auto now = Clock::now();
  next_commit_ = now + settings_.commit_every;
  if (collected_ > marked_) {
    JournalEntry mark;
    mark.kind = JournalEntry::Kind::reached;
    mark.tick = collected_ - 1;
    mark.wall_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                       std::chrono::system_clock::now().time_since_epoch())
                       .count();
    encode_entry(mark, batch_bytes_);
    batch_.emplace_back(collected_, batch_bytes_.size());
  }
  if (batch_.empty()) return;
  std::vector<store::RecordView> records;
  records.reserve(batch_.size());
  std::size_t begin = 0;
  for (const auto& [tick, end] : batch_) {
    records.push_back({tick, std::span<const std::byte>(batch_bytes_).subspan(begin, end - begin)});
    begin = end;
  }
  store::Status st;
  store::Health health;
  {
    std::lock_guard store_lock(store_mutex_);
    st = store_.append(records);  // a failed one is kept by the store and retried
    health = store_.health();
  }
  std::lock_guard lock(mutex_);
  stats_.entries += batch_.size();
  stats_.journal_bytes += batch_bytes_.size();
  ++stats_.commits;
  if (last_commit_ != Clock::time_point{})
    stats_.longest_commit_gap_ms =
        std::max(stats_.longest_commit_gap_ms, std::chrono::duration<double, std::milli>(now - last_commit_).count());
  last_commit_ = now;
  marked_ = collected_;
  batch_.clear();
  batch_bytes_.clear();
  if (!st.ok && !st.deferred && st.error != last_store_error_)
    log::warning("autosave: {}; the sculpt goes on in memory and the store is retried", st.error);
  if (st.ok && !last_store_error_.empty() && health_.degraded) log::notice("autosave: the store works again");
  if (!st.deferred) last_store_error_ = st.ok ? std::string() : st.error;
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
    if (caught_up && (Clock::now() >= next_snapshot_ || replayed_since_snapshot_ >= settings_.replay_work_per_snapshot))
      snapshot("periodic");
    if (stopping) break;
  }
  // The end: at normal priority, everything replayed, a last snapshot.
  set_background(false);
  replay_all();
  if (replica_) snapshot("at exit");
  finish_requests();
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
  } catch (const std::exception& e) {
    replica_.reset();
    log::err("autosave: cannot build the replica of the new scene ({}); the sculpt is not saved until the next scene",
             e.what());
    return;
  }
  bundle_key_.clear();
  bundle_stored_ = false;
  // The journal thread has written the scene's start; the next periodic
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
  if (r->kind == Request::Kind::export_file) {
    r->done(export_now());
    return;
  }
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
  HistoryInfo info;
  for (const Stroke& s : history_.strokes())
    info.strokes.push_back({s.number, s.body, s.scene, s.mesh, s.edit.tools, s.edit.first_tick,
                            s.edit.release_tick ? s.edit.release_tick : s.edit.last_tick, s.vertices, s.bytes(),
                            s.undone});
  info.budget = history_.budget();
  info.used = history_.used();
  info.dropped = history_.dropped();
  info.scene = replica_ ? replica_->scene_number() : 0;
  std::lock_guard lock(mutex_);
  stats_.replica_behind = replica_ && finished_ > replica_->next_tick() ? finished_ - replica_->next_tick() : 0;
  shown_ = std::move(info);
}

ExportResult Keeper::export_now() {
  catch_up();
  if (replica_) snapshot("export");
  const std::filesystem::path file = settings_.dir / fmt::format("export-{}.sculpt", ::getpid());
  std::error_code ec;
  std::filesystem::remove(file, ec);
  try {
    std::lock_guard store_lock(store_mutex_);
    store_.export_copy(file);
  } catch (const store::StoreError& e) {
    return ExportResult{e.what(), -1, 0};
  }
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  std::filesystem::remove(file, ec);  // the fd is the only way to it now
  if (fd < 0) return ExportResult{fmt::format("{}: cannot open the copy: {}", file.string(), std::strerror(errno)), -1, 0};
  const off_t size = ::lseek(fd, 0, SEEK_END);
  return ExportResult{{}, fd, static_cast<std::uint64_t>(size < 0 ? 0 : size)};
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
  return ask(std::move(r), std::move(out));
}

HistoryInfo Keeper::history() const {
  std::lock_guard lock(mutex_);
  return shown_;
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
