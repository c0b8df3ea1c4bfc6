// Building the byte arrays of the pads' tables (uhid_pads/*.cpp): little-endian
// fields, and the IMU calibration both Sony drivers read.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace sculpt::support::uhid_pads {

inline void put_le16(std::vector<std::uint8_t>& b, std::size_t at, int v) {
  b[at] = static_cast<std::uint8_t>(v & 0xff);
  b[at + 1] = static_cast<std::uint8_t>((v >> 8) & 0xff);
}
inline void put_le32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// The IMU calibration both Sony drivers read (DualSense 0x05, DS4 0x02 over
// USB share the layout): biases 0, ±range for each gyro and accelerometer axis.
// Non-zero ranges: the drivers divide by (plus - minus).
inline std::vector<std::uint8_t> sony_calibration(std::uint8_t id, std::size_t size) {
  std::vector<std::uint8_t> b(size, 0);
  b[0] = id;
  // 1..6 gyro biases (0); 7..18 gyro pitch/yaw/roll plus, minus.
  for (int axis = 0; axis < 3; ++axis) {
    put_le16(b, 7 + 4 * axis, 8192);
    put_le16(b, 9 + 4 * axis, -8192);
  }
  put_le16(b, 19, 540);  // gyro speed plus
  put_le16(b, 21, 540);  // gyro speed minus
  for (int axis = 0; axis < 3; ++axis) {  // 23..34 accelerometer x/y/z plus, minus
    put_le16(b, 23 + 4 * axis, 8192);
    put_le16(b, 25 + 4 * axis, -8192);
  }
  return b;
}

}  // namespace sculpt::support::uhid_pads
