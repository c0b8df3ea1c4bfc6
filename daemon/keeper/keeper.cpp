#include "keeper/keeper.hpp"

#include <pthread.h>

#include <algorithm>
#include <mutex>

#include "keeper/keeper_jobs.hpp"
#include "log/log.hpp"

namespace sculpt::daemon {
using namespace keeper_detail;

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
    e.number = next_scene_++;
    incoming_[e.number] = Incoming{std::move(bundle), std::move(scene), first_tick};
  }
  tap_.scene.store(e.number, std::memory_order_relaxed);
  // No sim thread runs: the io thread is the producer now. A full ring (a
  // journal thread held up by the disk) is waited out, for a while: the
  // entry marks where the old scene's input ends.
  for (int waited_ms = 0; !tap_.record(e); ++waited_ms) {
    if (waited_ms == 5000) {
      log::err("keeper: the journal stayed full for 5 s; the sculpt of the new scene is not saved");
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void Keeper::start_anew() {
  const store::Kept kind = unrecovered_ ? store::Kept::unrecovered : store::Kept::previous;
  const std::filesystem::path kept = store_.set_aside(kind);
  if (!kept.empty() && kind == store::Kept::previous)
    log::notice("keeper: the sculpt saved before is kept as {} (sculptd --open {} goes back to it)", kept.string(),
                kept.string());
  else if (!kept.empty())
    log::warning("keeper: the store that could not be recovered is kept as {}, as it was", kept.string());
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

// --- the io thread ------------------------------------------------------------------

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

kj::Promise<HistoryMoveResult> Keeper::move_history(bool undo, std::uint32_t count) {
  auto r = std::make_unique<Request>();
  r->kind = undo ? Request::Kind::undo : Request::Kind::redo;
  r->count = count;
  r->moved = std::make_shared<HistoryMoveResult>();
  auto out = r->moved;
  return ask(std::move(r), std::move(out));
}

kj::Promise<HistoryMoveResult> Keeper::undo(std::uint32_t count) { return move_history(true, count); }
kj::Promise<HistoryMoveResult> Keeper::redo(std::uint32_t count) { return move_history(false, count); }

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
