#include "app/options.hpp"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "cli/conventions.hpp"

namespace sculpt::view {

namespace {

std::vector<float> parse_floats(const std::string& text, const char* what) {
  std::vector<float> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const float v = std::strtof(item.c_str(), &end);
    if (item.empty() || end == nullptr || *end != '\0' || !std::isfinite(v)) {
      throw std::invalid_argument(fmt::format("{} '{}': '{}' is not a number", what, text, item));
    }
    out.push_back(v);
  }
  return out;
}

}  // namespace

std::pair<int, int> parse_size(const std::string& text) {
  int w = 0, h = 0;
  char x = 0, extra = 0;
  std::stringstream ss(text);
  if (!(ss >> w >> x >> h) || (x != 'x' && x != 'X') || (ss >> extra) || w < 16 || h < 16 || w > 16384 || h > 16384) {
    throw std::invalid_argument(fmt::format("--size '{}': expected WIDTHxHEIGHT, each 16..16384 (e.g. 1280x720)", text));
  }
  return {w, h};
}

void parse_camera(const std::string& text, CameraSpec& spec) {
  const auto v = parse_floats(text, "--camera");
  if (v.size() < 2 || v.size() > 3) {
    throw std::invalid_argument(fmt::format("--camera '{}': expected YAW,PITCH[,DISTANCE] (degrees, degrees, metres)", text));
  }
  spec.yaw_deg = v[0];
  spec.pitch_deg = v[1];
  if (v.size() == 3) {
    if (!(v[2] > 0)) throw std::invalid_argument(fmt::format("--camera '{}': distance must be > 0", text));
    spec.distance = v[2];
  }
}

std::array<float, 3> parse_vec3(const std::string& text, const char* what) {
  const auto v = parse_floats(text, what);
  if (v.size() != 3) throw std::invalid_argument(fmt::format("{} '{}': expected X,Y,Z", what, text));
  return {v[0], v[1], v[2]};
}

void check_outputs(const Options& o) {
  const auto dir = std::filesystem::path(o.screenshot).parent_path();
  if (!o.screenshot.empty() && !dir.empty() && !std::filesystem::is_directory(dir)) {
    throw std::runtime_error(fmt::format("{}: cannot write: no directory {}", o.screenshot, dir.string()));
  }
  if (!o.screenshot_dir.empty() && !std::filesystem::is_directory(o.screenshot_dir)) {
    throw std::runtime_error(fmt::format("--screenshot-dir {}: no such directory", o.screenshot_dir));
  }
}

std::optional<Options> parse_options(int argc, char** argv, int& exit_code) {
  Options o;
  CLI::App app{"sculpt-view: watch sculptd's meshes (headless PNGs or a window)"};
  cli::apply_conventions(app);
  app.set_version_flag("--version", std::string("sculpt-view 0.1.0 (protocol 1)"));
  std::string size = "1280x720", camera, target;
  long after_frames = -1;
  double after_seconds = -1;
  bool no_overlay = false, no_tools = false;
  app.add_option("--socket", o.socket, "sculptd's socket (default: $SCULPTD_SOCKET, $RUNTIME_DIRECTORY, "
                                        "$XDG_RUNTIME_DIR/sculptd, /run/sculptd)")->type_name("PATH");
  app.add_option("--scene", o.scene, "render a scene file (or builtin:default) without a daemon")->type_name("SCENE");
  app.add_flag("--headless", o.headless, "render offscreen (EGL surfaceless); the default without a display");
  app.add_flag("--window", o.window, "open a window (SDL2) even when --screenshot is given");
  auto* screenshot =
      app.add_option("--screenshot", o.screenshot, "write a PNG and exit (after --after-frames/--after-seconds)")
          ->type_name("FILE.png");
  // The option's old name: users' scripts still pass it.
  std::string deprecated_snapshot;
  app.add_option("--snapshot", deprecated_snapshot, "deprecated: --screenshot")
      ->type_name("FILE.png")
      ->excludes(screenshot)
      ->group("");  // not in --help
  app.add_option("--after-frames", after_frames, "frames to render (once the first state arrived) before --screenshot")
      ->check(CLI::Range(1L, 100000000L));
  app.add_option("--after-seconds", after_seconds, "seconds to run before --screenshot (or before exiting)")
      ->check(CLI::Range(0.0, 1e7));
  app.add_option("--frames-dir", o.frames_dir, "write every rendered frame as DIR/frame_NNNNNN.png")->type_name("DIR");
  app.add_option("--fps", o.fps, "frames rendered per second (and of --frames-dir)")->check(CLI::Range(0.1, 1000.0));
  app.add_option("--size", size, "image or window size WIDTHxHEIGHT")->type_name("WxH");
  app.add_option("--msaa", o.samples, "multisample count (0: off)")->check(CLI::Range(0, 16));
  app.add_flag("--wireframe", o.render.wireframe, "draw mesh edges");
  app.add_flag("--boxes", o.render.boxes, "draw the bounding boxes collision uses (meshes yellow, tools cyan)");
  app.add_flag("--colormap", o.render.colormap, "colour meshes by displacement from their rest shape");
  app.add_option("--colormap-range", o.render.colormap_range_m, "displacement (m) drawn fully red")
      ->check(CLI::Range(1e-6, 1e3));
  app.add_flag("--no-overlay", no_overlay, "no stats text");
  app.add_flag("--no-tools", no_tools, "do not draw tools and force arrows");
  app.add_option("--camera", camera, "YAW,PITCH[,DISTANCE]: orbit angles in degrees, distance in metres "
                                     "(default 20,25 and a distance that fits the scene)")->type_name("YAW,PITCH[,DIST]");
  app.add_option("--target", target, "X,Y,Z the camera looks at (default: the scene's centre)")->type_name("X,Y,Z");
  app.add_option("--tolerance", o.tolerance_m, "metres a vertex must move before the daemon resends it")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--max-fps", o.max_fps, "frames per second the daemon sends (default: --fps)")->check(CLI::Range(0.0, 10000.0));
  app.add_flag("--wait", o.wait, "keep retrying when no daemon listens yet (default: say so and exit 1)");
  app.add_option("--screenshot-dir", o.screenshot_dir, "where the window's screenshot key writes PNGs")->type_name("DIR");
  app.add_flag("-q,--quiet", o.quiet, "print only errors");
  if (const auto status = cli::parse(app, argc, argv)) {
    exit_code = *status;
    return std::nullopt;
  }
  if (!deprecated_snapshot.empty()) {
    cli::warning("--snapshot is deprecated: use --screenshot");
    o.screenshot = deprecated_snapshot;
  }
  try {
    std::tie(o.width, o.height) = parse_size(size);
    if (!camera.empty()) parse_camera(camera, o.camera);
    if (!target.empty()) o.camera.target = parse_vec3(target, "--target");
    if (after_frames > 0) o.after_frames = after_frames;
    if (after_seconds >= 0) o.after_seconds = after_seconds;
    if (o.headless && o.window) throw std::invalid_argument("--headless and --window exclude each other");
    if (!o.scene.empty() && !o.socket.empty()) throw std::invalid_argument("--scene (offline) and --socket exclude each other");
  } catch (const std::invalid_argument& e) {
    cli::error(e.what());
    exit_code = cli::kExitUsage;
    return std::nullopt;
  }
  o.render.overlay = !no_overlay;
  o.render.tools = !no_tools;
  o.render.arrows = !no_tools;
  return o;
}

}  // namespace sculpt::view
