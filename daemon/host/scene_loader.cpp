#include "host/scene_loader.hpp"

#include <optional>

#include "log/log.hpp"
#include "keeper/scene_bundle.hpp"

namespace sculpt::daemon {

void log_scene_warnings(const scene::Scene& s) {
  for (const auto& w : s.warnings) log::warning("scene {}: {}", s.file.string(), w);
  for (const auto& m : s.meshes)
    for (const auto& w : m.loaded.warnings) log::warning("scene {}: mesh {}: {}", s.file.string(), m.name, w);
}

std::size_t vertices_of(const scene::Scene& s) {
  std::size_t n = 0;
  for (const auto& m : s.meshes) n += m.loaded.mesh.positions.size();
  return n;
}

std::vector<std::string> mesh_names(const scene::Scene& s) {
  std::vector<std::string> names;
  for (const auto& m : s.meshes) names.push_back(m.name);
  return names;
}

kj::Promise<std::string> SceneLoader::load(std::function<SceneSource()> read, simloop::SimulationSettings settings,
                                           const char* what) {
  // Busy from the request until the swap: the build, and the wait for the sim thread to stop.
  if (loading_ || worker_.busy()) return std::string("a scene is being loaded already; try again when it is done");
  loading_ = true;
  struct Job {
    std::optional<Simulation> built;
    std::string error;
  };
  auto job = std::make_shared<Job>();
  haptics::FeedbackBoard& board = board_;
  auto done = worker_.run([job, read = std::move(read), settings, &board, copy = copies_for_replica_] {
    try {
      SceneSource source = read();
      source.bundle->settings = settings;
      auto replica_scene = copy ? std::make_shared<const scene::Scene>(source.scene) : nullptr;
      job->built.emplace(build_simulation(std::move(source.scene), settings, board));
      job->built->bundle = std::move(source.bundle);
      job->built->replica_scene = std::move(replica_scene);
    } catch (const std::exception& e) {
      job->error = e.what();
    }
  }).then([this, job, what]() -> kj::Promise<std::string> {
    if (!job->error.empty() || stopping_) {
      if (!job->error.empty()) log::warning("{}: {}; keeping the current sculpt", what, job->error);
      return job->error.empty() ? std::string("the daemon is stopping") : job->error;
    }
    log_scene_warnings(job->built->scene);
    return stop_sim_().then([this, job, what]() -> std::string {
      if (stopping_) return "the daemon is stopping";
      swap_in_(std::move(*job->built), what);
      return std::string();
    });
  }, [what](kj::Exception&& e) -> kj::Promise<std::string> {
    log::err("{}: {}", what, e.getDescription().cStr());
    return std::string(e.getDescription().cStr());
  }).then([this](std::string error) {
    loading_ = false;
    return error;
  }, [this](kj::Exception&& e) -> std::string {
    loading_ = false;
    log::err("scene load: {}", e.getDescription().cStr());
    return e.getDescription().cStr();
  });
  auto forked = done.fork();
  tasks_.add(forked.addBranch().ignoreResult());
  return forked.addBranch();
}

void SceneLoader::free_unfreed() {
  if (disposer_.busy() || unfreed_.empty()) return;
  std::vector<std::shared_ptr<void>> batch;
  batch.swap(unfreed_);
  // The last reference goes on the disposer thread; then whatever queued meanwhile.
  tasks_.add(disposer_.run([batch = std::move(batch)]() mutable { batch.clear(); }).then([this] { free_unfreed(); }));
}

}  // namespace sculpt::daemon
