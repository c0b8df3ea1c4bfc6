// How a snapshot's bytes are stored: a zstd frame that carries zstd's own
// content checksum (the low 32 bits of XXH64 of the original bytes), so any
// damage to a stored blob is found when it is decoded. Optionally the bytes
// are first regrouped by byte position within 4-byte words ("shuffle4"):
// the daemon's state is mostly float32 and int32 arrays, whose high bytes
// (sign, exponent) repeat across neighbours and compress once they sit
// together.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace sculpt::store {

// Stored in each snapshot row; a value this build does not know is reported
// as damage, not guessed at.
enum class Codec : std::int64_t {
  zstd = 1,           // zstd frame of the bytes as given
  shuffle4_zstd = 2,  // zstd frame of the bytes regrouped by position in 4-byte words
};

const char* codec_name(Codec c);

// The stored blob. `level` is zstd's (1-3 keep a 16 MB state under ~50 ms).
std::vector<std::byte> encode(std::span<const std::byte> raw, Codec codec, int level);

// Nothing decodes to more than this (a store file is untrusted input: a
// frame may declare any size, and zeros compress 30 000:1).
inline constexpr std::uint64_t kMaxDecodedBytes = std::uint64_t{1} << 30;

// The original bytes, or nullopt with `why` set ("checksum mismatch", "size
// 123 instead of 456", "unknown codec 7", "2147483648 bytes, more than the
// cap of 1073741824", ...). A `raw_size` above `max_bytes` is refused before
// anything is allocated or decoded; the frame is decoded as a stream into
// the one buffer of raw_size (the shuffle undone on the way), and a frame
// that would produce more than it declares is stopped there.
std::optional<std::vector<std::byte>> decode(std::span<const std::byte> blob, std::int64_t codec,
                                             std::uint64_t raw_size, std::string& why,
                                             std::uint64_t max_bytes = kMaxDecodedBytes);

// The regrouping on its own (exposed for the benchmark and tests): the k-th
// byte of every whole 4-byte word, for k = 0..3, then the tail as it was.
std::vector<std::byte> shuffle4(std::span<const std::byte> raw);
std::vector<std::byte> unshuffle4(std::span<const std::byte> shuffled);

}  // namespace sculpt::store
