#include "keeper/keeper.hpp"

#include <algorithm>
#include <mutex>

#include "keeper/keeper_jobs.hpp"
#include "log/log.hpp"

namespace sculpt::daemon {
using namespace keeper_detail;

namespace {
// A store with nothing to write looks at its files this often (taken away
// while the sculpt is paused, a second daemon could otherwise take the directory).
constexpr auto kIdleCheck = std::chrono::seconds(1);
}  // namespace

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
    log::warning("keeper: the daemon ends with {} journal records of {:.1f} s of sculpt not written to {} ({})",
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
    log::warning("keeper: {} ({}); the sculpt goes on in memory and the store is retried", st.error, what);
  if (st.ok && !last_store_error_.empty() && health_.degraded) log::notice("keeper: the store works again");
  if (!st.deferred) last_store_error_ = st.ok ? std::string() : st.error;
  if (health.relocations > relocations_seen_) {
    relocations_seen_ = health.relocations;
    log::warning("keeper: {}", health.relocation);
    snapshot_soon_ = true;  // a fresh one in the files as they are now
  }
  health_ = health;
}

}  // namespace sculpt::daemon
