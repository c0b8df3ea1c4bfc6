#include "store/codec.hpp"

#include <zstd.h>

#include <fmt/format.h>

#include <algorithm>
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

// The largest window a frame may ask for: levels 1-3 use at most 2^21, so a
// frame wanting more was not written by this codec (and zstd would allocate it).
constexpr int kMaxWindowLog = 23;
constexpr std::size_t kChunk = std::size_t{128} << 10;

// Where decoded bytes go: as they are, or (shuffle4) byte k of word w from
// stream position k·words + w, so the shuffle is undone without a second copy.
class Sink {
 public:
  Sink(std::vector<std::byte>& out, bool shuffled) : out_(out), words_(shuffled ? out.size() / 4 : 0) {}
  void put(const std::byte* p, std::size_t n) {
    while (n > 0) {
      if (at_ >= 4 * words_) {  // plain bytes, or the tail after the four planes
        std::copy(p, p + n, out_.data() + at_);
        at_ += n;
        return;
      }
      const std::size_t k = at_ / words_, w0 = at_ % words_;
      const std::size_t run = std::min(n, words_ - w0);
      std::byte* o = out_.data() + 4 * w0 + k;
      for (std::size_t j = 0; j < run; ++j) o[4 * j] = p[j];
      at_ += run, p += run, n -= run;
    }
  }

 private:
  std::vector<std::byte>& out_;
  std::size_t words_;
  std::size_t at_ = 0;
};

std::optional<std::vector<std::byte>> decompress(std::span<const std::byte> blob, std::uint64_t raw_size,
                                                 bool shuffled, std::uint64_t max_bytes, std::string& why) {
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
  // Before anything is allocated: the size a frame declares is the file's word.
  if (raw_size > max_bytes) {
    why = fmt::format("{} bytes, more than the cap of {}", raw_size, max_bytes);
    return std::nullopt;
  }
  const std::size_t frame = ZSTD_findFrameCompressedSize(blob.data(), blob.size());
  if (ZSTD_isError(frame)) {
    why = fmt::format("zstd: {}", ZSTD_getErrorName(frame));
    return std::nullopt;
  }
  if (frame != blob.size()) {
    why = fmt::format("{} bytes after the zstd frame", blob.size() - frame);
    return std::nullopt;
  }
  std::unique_ptr<ZSTD_DCtx, DctxFree> dctx(ZSTD_createDCtx());
  if (!dctx) throw std::bad_alloc();
  ZSTD_DCtx_setParameter(dctx.get(), ZSTD_d_windowLogMax, kMaxWindowLog);
  std::vector<std::byte> out(raw_size);
  Sink sink(out, shuffled);
  std::vector<std::byte> chunk(std::min<std::uint64_t>(kChunk, std::max<std::uint64_t>(raw_size, 1)));
  ZSTD_inBuffer in{blob.data(), blob.size(), 0};
  std::uint64_t produced = 0;
  for (;;) {
    ZSTD_outBuffer o{chunk.data(), chunk.size(), 0};
    const std::size_t left = ZSTD_decompressStream(dctx.get(), &o, &in);
    if (ZSTD_isError(left)) {
      why = fmt::format("zstd: {}", ZSTD_getErrorName(left));  // "Restored data doesn't match checksum"
      return std::nullopt;
    }
    if (o.pos > raw_size - produced) {  // zstd checks the size at the end; this stops it before
      why = fmt::format("decodes to more than the {} bytes it declares", raw_size);
      return std::nullopt;
    }
    sink.put(chunk.data(), o.pos);
    produced += o.pos;
    if (left == 0) break;  // the frame is complete, its checksum verified
    if (o.pos == 0 && in.pos == in.size) {
      why = "the zstd frame is truncated";
      return std::nullopt;
    }
  }
  if (produced != raw_size) {
    why = fmt::format("decoded {} bytes instead of {}", produced, raw_size);
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
                                             std::uint64_t raw_size, std::string& why, std::uint64_t max_bytes) {
  if (codec != static_cast<std::int64_t>(Codec::zstd) && codec != static_cast<std::int64_t>(Codec::shuffle4_zstd)) {
    why = fmt::format("unknown codec {}", codec);
    return std::nullopt;
  }
  return decompress(blob, raw_size, codec == static_cast<std::int64_t>(Codec::shuffle4_zstd), max_bytes, why);
}

}  // namespace sculpt::store
