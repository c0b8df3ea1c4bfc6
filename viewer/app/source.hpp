// Where the viewer's state comes from: a scene file rendered as loaded
// (offline), or sculptd's stream (live, with reconnection).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "app/options.hpp"
#include "render/model.hpp"

namespace sculpt::view {

class Source {
 public:
  virtual ~Source() = default;
  // Applies whatever arrived to the model, waiting at most `timeout_s` for it
  // (0: only what is already there). Throws std::runtime_error on a fatal error.
  virtual void pump(double timeout_s) = 0;
  // The first complete state (scene loaded, keyframe received) is in the model.
  virtual bool has_state() const = 0;
  // Overlay lines describing the source (stats, connection state).
  virtual std::vector<std::string> describe() const = 0;
  ViewModel& model() { return model_; }

 protected:
  ViewModel model_;
};

// Loads the scene through daemon/scene; throws std::runtime_error naming the
// file and what is wrong.
std::unique_ptr<Source> make_offline_source(const std::string& scene_file);
// Builds a model from a loaded scene (meshes at their loaded positions, tools at their start).
void fill_from_scene_file(ViewModel& model, const std::string& scene_file);

// Connects to sculptd (throws std::runtime_error "no daemon is listening on
// PATH ..." unless options.wait), subscribes, and reconnects whenever the
// daemon goes away.
std::unique_ptr<Source> make_live_source(const Options& options);

}  // namespace sculpt::view
