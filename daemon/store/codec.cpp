#include "store/codec.hpp"

#include <zstd.h>

#include <fmt/format.h>

#include <memory>
#include <stdexcept>

namespace sculpt::store {
namespace {

struct CctxFree {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DctxFree {
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

std::vector<std::byte> compress(std::span<const std::byte> raw, int level) {
  std::unique_ptr<ZSTD_CCtx, CctxFree> cctx(ZSTD_createCCtx());
  if (!cctx) throw std::bad_alloc();
  ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_compressionLevel, level);
  ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_checksumFlag, 1);
  // The size goes into the frame header so decode can check it up front.
  ZSTD_CCtx_setPledgedSrcSize(cctx.get(), raw.size());
  std::vector<std::byte> out(ZSTD_compressBound(raw.size()));
  const std::size_t n = ZSTD_compress2(cctx.get(), out.data(), out.size(), raw.data(), raw.size());
  if (ZSTD_isError(n)) throw std::runtime_error(fmt::format("zstd: {}", ZSTD_getErrorName(n)));
  out.resize(n);
  return out;
}

std::optional<std::vector<std::byte>> decompress(std::span<const std::byte> blob, std::uint64_t raw_size,
                                                 std::string& why) {
  // The frame format is RFC 8878: a 4-byte magic number, then the frame
  // header descriptor whose bit 2 says a content checksum follows the data.
  // A flipped bit could clear that flag and with it the check itself.
  if (blob.size() < 5 || (std::to_integer<unsigned>(blob[4]) & 0x04) == 0) {
    why = blob.size() < 5 ? "too short for a zstd frame" : "the zstd frame has no checksum";
    return std::nullopt;
  }
  const unsigned long long content = ZSTD_getFrameContentSize(blob.data(), blob.size());
  if (content == ZSTD_CONTENTSIZE_ERROR || content == ZSTD_CONTENTSIZE_UNKNOWN) {
    why = "not a zstd frame with its size";
    return std::nullopt;
  }
  if (content != raw_size) {
    why = fmt::format("the frame says {} bytes, the row {}", content, raw_size);
    return std::nullopt;
  }
  std::unique_ptr<ZSTD_DCtx, DctxFree> dctx(ZSTD_createDCtx());
  if (!dctx) throw std::bad_alloc();
  std::vector<std::byte> out(raw_size);
  const std::size_t n = ZSTD_decompressDCtx(dctx.get(), out.data(), out.size(), blob.data(), blob.size());
  if (ZSTD_isError(n)) {
    why = fmt::format("zstd: {}", ZSTD_getErrorName(n));  // "Restored data doesn't match checksum"
    return std::nullopt;
  }
  if (n != raw_size) {
    why = fmt::format("decoded {} bytes instead of {}", n, raw_size);
    return std::nullopt;
  }
  return out;
}

}  // namespace

const char* codec_name(Codec c) {
  switch (c) {
    case Codec::zstd: return "zstd";
    case Codec::shuffle4_zstd: return "shuffle4+zstd";
  }
  return "unknown";
}

std::vector<std::byte> shuffle4(std::span<const std::byte> raw) {
  std::vector<std::byte> out(raw.size());
  const std::size_t words = raw.size() / 4;
  for (std::size_t k = 0; k < 4; ++k)
    for (std::size_t w = 0; w < words; ++w) out[k * words + w] = raw[w * 4 + k];
  for (std::size_t i = words * 4; i < raw.size(); ++i) out[i] = raw[i];
  return out;
}

std::vector<std::byte> unshuffle4(std::span<const std::byte> shuffled) {
  std::vector<std::byte> out(shuffled.size());
  const std::size_t words = shuffled.size() / 4;
  for (std::size_t k = 0; k < 4; ++k)
    for (std::size_t w = 0; w < words; ++w) out[w * 4 + k] = shuffled[k * words + w];
  for (std::size_t i = words * 4; i < shuffled.size(); ++i) out[i] = shuffled[i];
  return out;
}

std::vector<std::byte> encode(std::span<const std::byte> raw, Codec codec, int level) {
  if (codec == Codec::shuffle4_zstd) return compress(shuffle4(raw), level);
  return compress(raw, level);
}

std::optional<std::vector<std::byte>> decode(std::span<const std::byte> blob, std::int64_t codec,
                                             std::uint64_t raw_size, std::string& why) {
  if (codec != static_cast<std::int64_t>(Codec::zstd) && codec != static_cast<std::int64_t>(Codec::shuffle4_zstd)) {
    why = fmt::format("unknown codec {}", codec);
    return std::nullopt;
  }
  auto out = decompress(blob, raw_size, why);
  if (out && codec == static_cast<std::int64_t>(Codec::shuffle4_zstd)) return unshuffle4(*out);
  return out;
}

}  // namespace sculpt::store
