#include "haptics/ff_port.hpp"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdint>
#include <system_error>

namespace sculpt::haptics {
namespace {

class EvdevFfPort final : public FfPort {
 public:
  explicit EvdevFfPort(std::string node) : node_(std::move(node)) {
    fd_ = ::open(node_.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) throw std::system_error(errno, std::generic_category(), "open " + node_ + " for force feedback");
    mask_input_events();
  }
  ~EvdevFfPort() override {
    // close() flushes this file's effects in the kernel (a stop and an erase
    // each): a crash never leaves a force playing.
    ::close(fd_);
  }
  EvdevFfPort(const EvdevFfPort&) = delete;
  EvdevFfPort& operator=(const EvdevFfPort&) = delete;

  FfCaps caps() override {
    FfCaps caps;
    unsigned long words[(FF_CNT + sizeof(unsigned long) * CHAR_BIT - 1) / (sizeof(unsigned long) * CHAR_BIT)] = {};
    if (::ioctl(fd_, EVIOCGBIT(EV_FF, sizeof(words)), words) >= 0) {
      constexpr std::size_t bits_per_word = sizeof(unsigned long) * CHAR_BIT;
      for (std::size_t b = 0; b < FF_CNT; ++b)
        if (words[b / bits_per_word] & (1UL << (b % bits_per_word))) caps.bits.set(b);
    }
    int n = 0;
    if (::ioctl(fd_, EVIOCGEFFECTS, &n) >= 0) caps.effects_max = n;
    return caps;
  }

  DeviceIdentity identity() override {
    DeviceIdentity out;
    input_id id{};
    if (::ioctl(fd_, EVIOCGID, &id) >= 0) {
      out.bustype = id.bustype;
      out.vendor = id.vendor;
      out.product = id.product;
    }
    char name[256] = {};
    if (::ioctl(fd_, EVIOCGNAME(sizeof name - 1), name) >= 0) out.name = name;
    return out;
  }

  int upload(ff_effect& effect) override {
    while (::ioctl(fd_, EVIOCSFF, &effect) < 0) {
      if (errno != EINTR) return errno;
    }
    return 0;
  }

  int erase(std::int16_t id) override {
    while (::ioctl(fd_, EVIOCRMFF, static_cast<long>(id)) < 0) {
      if (errno != EINTR) return errno;
    }
    return 0;
  }

  int write_ff(std::uint16_t code, std::int32_t value) override {
    input_event ev{};
    ev.type = EV_FF;
    ev.code = code;
    ev.value = value;
    for (;;) {
      const ssize_t n = ::write(fd_, &ev, sizeof ev);
      if (n == static_cast<ssize_t>(sizeof ev)) return 0;
      if (n < 0 && errno == EINTR) continue;
      return n < 0 ? errno : EIO;
    }
  }

  const std::string& node() const override { return node_; }

 private:
  // This fd only sends FF; without a mask every input event of the device
  // would also queue here, unread. EVIOCSMASK (Linux 4.4+) filters them per
  // file; an older kernel refuses and the queue merely overflows (harmless).
  void mask_input_events() {
    static const unsigned char none[(KEY_CNT + 7) / 8] = {};
    for (unsigned type = EV_KEY; type < EV_CNT; ++type) {
      if (type == EV_FF) continue;
      input_mask mask{};
      mask.type = type;
      mask.codes_size = sizeof none;
      mask.codes_ptr = reinterpret_cast<std::uintptr_t>(none);
      (void)::ioctl(fd_, EVIOCSMASK, &mask);
    }
  }

  std::string node_;
  int fd_ = -1;
};

}  // namespace

std::unique_ptr<FfPort> open_evdev_port(const std::string& node) { return std::make_unique<EvdevFfPort>(node); }

}  // namespace sculpt::haptics
