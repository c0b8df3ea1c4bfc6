#include "keeper/save_marker.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace sculpt::daemon {
namespace {

constexpr std::size_t kPadded = 1024;  // rewritten in place at one size: no truncate, no torn tail

std::uint64_t fnv1a(std::string_view s) {
  std::uint64_t h = 1469598103934665603ull;
  for (char c : s) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  return h;
}

std::string boot_id() {
  std::ifstream in("/proc/sys/kernel/random/boot_id");
  std::string id;
  std::getline(in, id);
  return id;
}

std::string canonical_text(const std::filesystem::path& dir) {
  std::error_code ec;
  const auto c = std::filesystem::weakly_canonical(dir, ec);
  return (ec ? dir : c).string();
}

}  // namespace

std::filesystem::path runtime_dir() {
  namespace fs = std::filesystem;
  if (const char* d = std::getenv("RUNTIME_DIRECTORY"); d && *d) return std::string(d).substr(0, std::string(d).find(':'));
  if (const char* d = std::getenv("XDG_RUNTIME_DIR"); d && *d) return d;
  std::error_code ec;
  return fs::is_directory("/dev/shm", ec) ? "/dev/shm" : "/tmp";
}

std::filesystem::path SaveMarker::path_for(const std::filesystem::path& store_dir) {
  return runtime_dir() / fmt::format("sculptd-store-{:016x}.state", fnv1a(canonical_text(store_dir)));
}

std::optional<SaveState> SaveMarker::read(const std::filesystem::path& store_dir) {
  std::ifstream in(path_for(store_dir));
  if (!in) return std::nullopt;
  std::stringstream ss;
  ss << in.rdbuf();
  try {
    const nlohmann::json j = nlohmann::json::parse(ss.str());
    if (j.at("dir").get<std::string>() != canonical_text(store_dir) || j.at("boot").get<std::string>() != boot_id())
      return std::nullopt;
    SaveState s;
    s.pid = j.at("pid").get<std::int64_t>();
    s.ran = j.at("ran").get<std::uint64_t>();
    s.committed = j.at("committed").get<std::uint64_t>();
    s.failing_since_ns = j.at("failing_since_ns").get<std::int64_t>();
    s.error = j.at("error").get<std::string>();
    s.unnamed = j.at("unnamed").get<bool>();
    s.ended = j.at("ended").get<bool>();
    return s;
  } catch (const std::exception&) {
    return std::nullopt;  // not ours, or torn by a crash mid-write: nothing can be said from it
  }
}

SaveMarker::SaveMarker(const std::filesystem::path& store_dir) : path_(path_for(store_dir)) {
  header_ = nlohmann::json{{"dir", canonical_text(store_dir)}, {"boot", boot_id()}}.dump();
}

void SaveMarker::write(const SaveState& s) {
  // Made at the first write: a daemon that never ran leaves the last one's as it was.
  if (!fd_.valid() && !tried_) fd_ = files::UniqueFd(::open(path_.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0600));
  tried_ = true;
  if (!fd_.valid()) return;
  nlohmann::json j = nlohmann::json::parse(header_);
  j.update(nlohmann::json{{"pid", s.pid},
                          {"ran", s.ran},
                          {"committed", s.committed},
                          {"failing_since_ns", s.failing_since_ns},
                          {"error", s.error.substr(0, 600)},
                          {"unnamed", s.unnamed},
                          {"ended", s.ended}});
  std::string text = j.dump();
  if (text.size() > kPadded) return;
  text.resize(kPadded, ' ');  // trailing blanks: a longer earlier write leaves nothing behind
  [[maybe_unused]] const ssize_t n = ::pwrite(fd_.get(), text.data(), text.size(), 0);
}

void SaveMarker::remove() {
  fd_.reset();
  tried_ = false;
  ::unlink(path_.c_str());
}

}  // namespace sculpt::daemon
