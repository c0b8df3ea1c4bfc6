// FF_RUMBLE through the kernel's own gamepad drivers, as any evdev client
// sends it: each test asserts on the motor bytes of the output reports the
// driver (hid-playstation, hid-sony, hid-microsoft, all on ff-memless) sends
// to the uhid pad. Facts are waited for, never slept for.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "support/evdev_client.hpp"
#include "support/uhid_pad.hpp"
#include "pad_cases.hpp"

namespace sculpt::support {
namespace {

using namespace std::chrono_literals;
using uhidtest::motor_byte;

class UhidFf : public ::testing::TestWithParam<const UhidPadSpec*> {};

TEST_P(UhidFf, RumbleReachesTheMotorsUpdatesInPlaceAndStops) {
  const UhidPadSpec& spec = *GetParam();
  UhidPad pad(spec);
  EvdevClient ev(pad.ff_node());
  ASSERT_TRUE(ev.has_ff(FF_RUMBLE));

  ff_effect e = rumble_effect(0x8000, 0x4000, 0);  // length 0: until stopped
  ASSERT_EQ(ev.upload(e), 0);
  const std::int16_t id = e.id;
  ASSERT_GE(id, 0);
  ASSERT_EQ(ev.play(id), 0);
  const Motors first{motor_byte(spec, 0x8000), motor_byte(spec, 0x4000)};
  ASSERT_TRUE(pad.wait_for_motors([&](const Motors& m) { return m == first; }))
      << "last motors " << (pad.last_motors() ? int(pad.last_motors()->strong) : -1) << "/"
      << (pad.last_motors() ? int(pad.last_motors()->weak) : -1);
  EXPECT_EQ(first.strong, spec.motor_max == 100 ? 50 : 128);  // strong → the strong (left) motor
  EXPECT_EQ(first.weak, spec.motor_max == 100 ? 25 : 64);
  {  // The report as sent, in the log: what the driver does is the fact under test.
    const auto rs = pad.outputs();
    for (auto it = rs.rbegin(); it != rs.rend(); ++it) {
      if (!spec.motors(*it)) continue;
      std::printf("%s motor report (%zu bytes):", spec.module.c_str(), it->data.size());
      for (std::size_t i = 0; i < std::min<std::size_t>(it->data.size(), 12); ++i) std::printf(" %02x", it->data[i]);
      std::printf("\n");
      break;
    }
  }

  // The same effect id, new magnitudes: the playing effect changes in place.
  ff_effect upd = rumble_effect(0xffff, 0x1000, 0, id);
  ASSERT_EQ(ev.upload(upd), 0);
  EXPECT_EQ(upd.id, id);
  const Motors second{spec.motor_max, motor_byte(spec, 0x1000)};
  ASSERT_TRUE(pad.wait_for_motors([&](const Motors& m) { return m == second; }));

  ASSERT_EQ(ev.stop(id), 0);
  ASSERT_TRUE(pad.wait_for_motors([](const Motors& m) { return m == Motors{0, 0}; }));
  EXPECT_EQ(ev.erase(id), 0);
}

TEST_P(UhidFf, ClosingTheNodeStopsAPlayingRumble) {
  const UhidPadSpec& spec = *GetParam();
  UhidPad pad(spec);
  {
    EvdevClient ev(pad.ff_node());
    ff_effect e = rumble_effect(0xc000, 0xc000, 0);
    ASSERT_EQ(ev.upload(e), 0);
    ASSERT_EQ(ev.play(e.id), 0);
    ASSERT_TRUE(pad.wait_for_motors([](const Motors& m) { return m.strong > 0 && m.weak > 0; }));
  }  // close: the kernel erases the client's effects, ff-memless stops them
  ASSERT_TRUE(pad.wait_for_motors([](const Motors& m) { return m == Motors{0, 0}; }));
}

// A process holding the node with a rumble playing dies by SIGKILL: no
// cleanup of its own runs, the kernel closes its fd (evdev flushes the
// client's effects, ff-memless stops the playing one) and the pad is told
// motors 0.
TEST_P(UhidFf, SigkilledClientsRumbleStops) {
  const UhidPadSpec& spec = *GetParam();
  UhidPad pad(spec);
  const std::string node = pad.ff_node();
  ff_effect e = rumble_effect(0xffff, 0x8000, 0);  // built before fork: the child only makes syscalls
  int ready[2];
  ASSERT_EQ(::pipe2(ready, O_CLOEXEC), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // Only async-signal-safe calls here: the parent has threads.
    ::close(ready[0]);
    const int fd = ::open(node.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0 || ::ioctl(fd, EVIOCSFF, &e) < 0) ::_exit(2);
    input_event play{};
    play.type = EV_FF;
    play.code = static_cast<std::uint16_t>(e.id);
    play.value = 1;
    if (::write(fd, &play, sizeof play) != static_cast<ssize_t>(sizeof play)) ::_exit(3);
    const char ok = 'k';
    (void)!::write(ready[1], &ok, 1);
    for (;;) ::pause();
  }
  ::close(ready[1]);
  char c = 0;
  const ssize_t n = ::read(ready[0], &c, 1);
  ::close(ready[0]);
  if (n != 1) {
    int st = 0;
    ::waitpid(child, &st, 0);
    FAIL() << "the child could not upload and play (exit status " << WEXITSTATUS(st) << ")";
  }
  const Motors playing{spec.motor_max, motor_byte(spec, 0x8000)};
  ASSERT_TRUE(pad.wait_for_motors([&](const Motors& m) { return m == playing; }));
  const std::size_t before = pad.output_count();
  ASSERT_EQ(::kill(child, SIGKILL), 0);
  int st = 0;
  ASSERT_EQ(::waitpid(child, &st, 0), child);
  ASSERT_TRUE(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL);
  ASSERT_TRUE(pad.wait_for([&](const std::vector<OutputReport>& rs) {
    for (std::size_t i = before; i < rs.size(); ++i)
      if (auto m = spec.motors(rs[i]); m && *m == Motors{0, 0}) return true;
    return false;
  })) << "no motor-0 report after the SIGKILL";
}

INSTANTIATE_TEST_SUITE_P(Pads, UhidFf, ::testing::ValuesIn(uhid_pads::all()), uhidtest::PadName{});

}  // namespace
}  // namespace sculpt::support
