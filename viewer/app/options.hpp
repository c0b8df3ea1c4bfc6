// sculpt-view's command line (docs/viewer.md lists every option).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "render/renderer.hpp"

namespace sculpt::view {

struct CameraSpec {
  std::optional<float> yaw_deg, pitch_deg, distance;
  std::optional<std::array<float, 3>> target;
};

struct Options {
  std::string socket;              // explicit --socket (else the client's path rule)
  std::string scene;               // --scene FILE|builtin:default: offline, no daemon
  bool headless = false;           // forced, or chosen because no display exists
  bool window = false;             // forced --window
  std::string screenshot;          // --screenshot FILE.png
  std::optional<long> after_frames;
  std::optional<double> after_seconds;
  std::string frames_dir;          // --frames-dir DIR
  double fps = 30.0;               // render rate (and image-sequence rate)
  int width = 1280, height = 720;
  int samples = 4;                 // MSAA
  RenderOptions render;
  CameraSpec camera;
  float tolerance_m = 1e-4f;       // subscribe: vertices that moved less are not sent
  float max_fps = 0;               // subscribe: 0 = --fps
  bool wait = false;               // keep retrying when no daemon listens at start
  bool quiet = false;
  std::string screenshot_dir = ".";
};

// Parses argv; on --help/--version or an error prints and returns the exit
// code to use (0 or 2) in `exit_code` and nullopt.
std::optional<Options> parse_options(int argc, char** argv, int& exit_code);
// Before the run: throws std::runtime_error naming a --screenshot whose
// directory is missing, found now rather than after the run it was to record.
void check_outputs(const Options& options);

// "1280x720" -> {1280, 720}; throws std::invalid_argument naming the value.
std::pair<int, int> parse_size(const std::string& text);
// "yaw,pitch[,distance]" -> spec; throws std::invalid_argument.
void parse_camera(const std::string& text, CameraSpec& spec);
std::array<float, 3> parse_vec3(const std::string& text, const char* what);

}  // namespace sculpt::view
