// libFuzzer over everything sculptd reads from a store (a .sculpt file is
// untrusted input): the SQLite file as `--open` takes it, the codec, the
// scene bundle, the journal codec, the replica's state restore and block
// images, and a whole recovery of a store made from a real sculpt and then
// altered (the input's format: store_fuzz_base.hpp). Whatever the input,
// recovery must refuse by name or recover; no crash, no leak, memory within
// the caps (this target runs with -rss_limit_mb=1024) and time bounded (the
// replay's own limits, set small here).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <algorithm>

#include "keeper/journal_codec.hpp"
#include "keeper/keeper.hpp"
#include "log/log.hpp"
#include "store/codec.hpp"
#include "store/store.hpp"
#include "store_fuzz_base.hpp"

namespace {

using namespace sculpt;
namespace fs = std::filesystem;

// Reads the input front to back; short reads give zeros and stop.
class Input {
 public:
  Input(const std::uint8_t* data, std::size_t size) : p_(data), left_(size) {}
  bool empty() const { return left_ == 0; }
  template <class T>
  T get() {
    T v{};
    const std::size_t n = std::min(sizeof v, left_);
    std::memcpy(&v, p_, n);
    p_ += n, left_ -= n;
    return v;
  }
  std::span<const std::uint8_t> take(std::size_t n) {
    n = std::min(n, left_);
    const std::span<const std::uint8_t> s(p_, n);
    p_ += n, left_ -= n;
    return s;
  }
  std::span<const std::uint8_t> rest() { return take(left_); }

 private:
  const std::uint8_t* p_;
  std::size_t left_;
};

std::span<const std::byte> bytes(std::span<const std::uint8_t> s) { return std::as_bytes(s); }

void patch(std::vector<std::byte>& target, Input& in) {
  if (target.empty()) return;
  const std::uint32_t at = in.get<std::uint32_t>() % target.size();
  const auto with = in.rest();
  for (std::size_t i = 0; i < with.size() && at + i < target.size(); ++i) target[at + i] = static_cast<std::byte>(with[i]);
}

fuzz::Base& base() {
  static fuzz::Base* b = [] {
    log::set_level(log::Level::err);  // refusals are the point; the log would drown the fuzzer's
    return new fuzz::Base();
  }();
  return *b;
}

// A private directory for the stores, removed when the fuzzer exits; in
// memory where it can be (every commit is fsynced).
const fs::path& work_dir() {
  static const struct Dir {
    fs::path path = (fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path()) /
                    ("sculpt-store-fuzz-" + std::to_string(::getpid()));
    Dir() {
      fs::remove_all(path);
      fs::create_directories(path);
    }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } dir;
  return dir.path;
}

// Small caps, so that what a file may make recovery hold stays far below
// the RSS limit: the state and blobs 64 MiB, the history 16 MiB, the
// journal 16 MiB; the replay at most a minute of ticks and a second.
daemon::KeeperSettings settings(const fs::path& dir) {
  daemon::KeeperSettings s;
  s.dir = dir;
  s.history_budget = std::uint64_t{16} << 20;
  s.replay_span_limit = std::chrono::seconds(60);
  s.replay_time_limit = std::chrono::milliseconds(1000);
  s.limits.max_decoded_bytes = std::uint64_t{64} << 20;
  s.limits.max_journal_bytes = std::uint64_t{16} << 20;
  s.limits.max_journal_records = std::uint64_t{1} << 16;
  return s;
}

void recover(const fs::path& dir) {
  try {
    daemon::JournalTap tap(16);  // recovery records nothing
    daemon::Keeper keeper(settings(dir), tap);
    (void)keeper.recover();
  } catch (const store::StoreError&) {  // not a store, a newer schema: refused by name
  }
}

fs::path fresh_store_dir() {
  const fs::path dir = work_dir() / "store";
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The next [kind u8][length u16][payload] section, or none.
std::optional<std::pair<char, Input>> next_section(Input& in) {
  if (in.empty()) return std::nullopt;
  const char kind = static_cast<char>(in.get<std::uint8_t>());
  const auto payload = in.take(in.get<std::uint16_t>());
  return std::pair{kind, Input(payload.data(), payload.size())};
}

// A store made from the base sculpt with the input's sections applied,
// written through the store (so every frame is whole and its checksum
// right), then recovered.
void altered_store(Input& in) {
  fuzz::Base& b = base();
  std::vector<std::byte> state = b.state, bundle = b.bundle_bytes;
  std::optional<std::string> meta;
  std::uint64_t row_tick = b.meta.at("next_tick").get<std::uint64_t>();
  std::vector<std::vector<std::byte>> strokes{b.stroke};
  std::vector<store::Record> journal;
  while (auto sec = next_section(in)) {
    Input& p = sec->second;
    switch (sec->first) {
      case 'S': patch(state, p); break;
      case 'B': patch(bundle, p); break;
      case 'K': {
        std::vector<std::byte> stroke = b.stroke;
        patch(stroke, p);
        strokes.push_back(std::move(stroke));
        break;
      }
      case 'M': {
        const auto text = p.rest();
        meta = std::string(reinterpret_cast<const char*>(text.data()), text.size());
        break;
      }
      case 'J': {
        const std::uint64_t ticks = p.get<std::uint16_t>();
        const auto record = bytes(p.rest());
        journal.push_back({row_tick + 1 + ticks, {record.begin(), record.end()}});
        break;
      }
      case 'T': row_tick += p.get<std::uint32_t>(); break;
      default: break;
    }
  }
  std::vector<std::string> keys{b.bundle_key};
  std::vector<store::BlobWrite> blobs{{b.bundle_key, bundle}};
  nlohmann::json listed = nlohmann::json::array();
  for (std::size_t i = 0; i < strokes.size(); ++i) keys.push_back(i == 0 ? b.stroke_key : "stroke/fuzz-k" + std::to_string(i));
  for (std::size_t i = 0; i < strokes.size(); ++i) {
    blobs.push_back({keys[i + 1], strokes[i]});
    listed.push_back(keys[i + 1]);
  }
  if (!meta) {
    nlohmann::json m = b.meta;
    m["strokes"] = listed;
    m["next_stroke"] = strokes.size() + 1;
    meta = m.dump();
  }
  std::sort(journal.begin(), journal.end(), [](const auto& x, const auto& y) { return x.tick < y.tick; });
  const fs::path dir = fresh_store_dir();
  try {
    store::Store st = store::Store::open(dir, settings(dir).limits);
    (void)st.write_snapshot(row_tick, state, *meta, blobs, keys);
    std::vector<store::RecordView> views;
    for (const store::Record& r : journal) views.push_back({r.tick, r.bytes});
    (void)st.append(views);
  } catch (const store::StoreError&) {
    return;
  }
  recover(dir);
}

// The base state patched, restored on the base's replica and stepped.
void restore_on_replica(Input& in) {
  fuzz::Base& b = base();
  std::vector<std::byte> state = b.state;
  while (auto sec = next_section(in))
    if (sec->first == 'S') patch(state, sec->second);
  try {
    b.replica->restore_state(state);
  } catch (const std::invalid_argument&) {
    return;
  }
  b.replica->advance_to(b.replica->next_tick() + 3);
}

// A block image of the base's world, patched: swapped in and stepped when
// the check passes.
void block_image(Input& in) {
  fuzz::Base& b = base();
  sim::World<float>& w = b.replica->world();
  const std::uint32_t body = in.get<std::uint32_t>(), block = in.get<std::uint32_t>();
  const std::uint32_t real_body = body % w.body_count(), real_block = block % w.body(real_body).blocks;
  std::vector<std::byte> image(w.block_image_bytes(real_body));
  w.block_image(real_body, real_block, image);
  patch(image, in);
  if (!w.block_image_error(body, block, image).empty()) return;
  w.close_strokes();
  w.exchange_block_image(body, block, image);
  b.replica->advance_to(b.replica->next_tick() + 2);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  Input in(data + 1, size - 1);
  switch (data[0]) {
    case 'F': {
      const fs::path dir = fresh_store_dir();
      const auto file = in.rest();
      std::ofstream(dir / "store.db", std::ios::binary)
          .write(reinterpret_cast<const char*>(file.data()), static_cast<std::streamsize>(file.size()));
      recover(dir);
      break;
    }
    case 'P': altered_store(in); break;
    case 'R': restore_on_replica(in); break;
    case 'I': block_image(in); break;
    case 'Z': {
      const auto codec = in.get<std::uint8_t>();
      const auto raw_size = in.get<std::uint32_t>();
      std::string why;
      (void)store::decode(bytes(in.rest()), codec, raw_size, why, std::uint64_t{1} << 20);
      break;
    }
    case 'U':
      try {
        (void)daemon::SceneBundle::from_bytes(bytes(in.rest()));
      } catch (const std::invalid_argument&) {
      }
      break;
    case 'E': {
      std::string why;
      (void)daemon::decode_entry(bytes(in.rest()), 0, why);
      break;
    }
    default: break;
  }
  return 0;
}
