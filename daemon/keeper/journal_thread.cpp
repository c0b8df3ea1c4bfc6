#include "keeper/keeper.hpp"

#include <algorithm>
#include <mutex>

#include "keeper/journal_codec.hpp"
#include "keeper/keeper_jobs.hpp"
#include "log/log.hpp"

namespace sculpt::daemon {
using namespace keeper_detail;

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
        if (const auto it = incoming_.find(e->number); it != incoming_.end()) job->bundle = it->second.bundle;
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

}  // namespace sculpt::daemon
