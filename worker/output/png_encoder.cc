#include "worker/output/png_encoder.h"

#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <system_error>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "worker/output/map_writer.h"

namespace impostor {
namespace {

constexpr size_t kWindowBytes = 32768;  // deflate's window: a dictionary longer is never read
constexpr uint8_t kFilterUp = 2;        // PNG spec 9.2
constexpr size_t kIdatBytes = size_t{1} << 20;
constexpr int kMaxThreads = 16;

// One image's rows as the PNG stores them: big-endian samples.
struct Rows {
  const void* pixels;
  int width, height;
  int sample_bytes;  // 1 or 2
  size_t line() const { return 1 + static_cast<size_t>(width) * 4 * sample_bytes; }  // filter byte + row
};

// Appends rows [y0, y1) Up-filtered: each byte minus the byte above it.
void FilterRows(const Rows& rows, int y0, int y1, std::vector<uint8_t>* out) {
  const size_t values = static_cast<size_t>(rows.width) * 4;
  for (int y = y0; y < y1; ++y) {
    out->push_back(kFilterUp);
    if (rows.sample_bytes == 1) {
      const auto* row = static_cast<const uint8_t*>(rows.pixels) + static_cast<size_t>(y) * values;
      for (size_t i = 0; i < values; ++i) out->push_back(static_cast<uint8_t>(row[i] - (y > 0 ? row[i - values] : 0)));
    } else {
      const auto* row = static_cast<const uint16_t*>(rows.pixels) + static_cast<size_t>(y) * values;
      for (size_t i = 0; i < values; ++i) {
        const uint16_t v = row[i], above = y > 0 ? row[i - values] : 0;
        out->push_back(static_cast<uint8_t>((v >> 8) - (above >> 8)));
        out->push_back(static_cast<uint8_t>((v & 0xff) - (above & 0xff)));
      }
    }
  }
}

struct Band {
  int y0 = 0, y1 = 0;
  std::string deflated;
  uLong adler = 1;      // Adler-32 of the band's filtered bytes alone
  size_t length = 0;    // filtered bytes
  int zlib_error = Z_OK;
};

void DeflateBand(const Rows& rows, bool last, Band* band) {
  std::vector<uint8_t> input;
  input.reserve(static_cast<size_t>(band->y1 - band->y0) * rows.line());
  FilterRows(rows, band->y0, band->y1, &input);
  band->length = input.size();
  band->adler = adler32_z(adler32_z(0, nullptr, 0), input.data(), input.size());
  z_stream z{};
  // Raw deflate (negative window bits): the zlib header and trailer are
  // written once for the whole stream.
  if ((band->zlib_error = deflateInit2(&z, kPngCompressionLevel, Z_DEFLATED, -15, 8, Z_FILTERED)) != Z_OK) return;
  if (band->y0 > 0) {
    const int back = static_cast<int>(std::min<size_t>(band->y0, kWindowBytes / rows.line() + 1));
    std::vector<uint8_t> before;
    FilterRows(rows, band->y0 - back, band->y0, &before);
    const size_t n = std::min(before.size(), kWindowBytes);
    band->zlib_error = deflateSetDictionary(&z, before.data() + before.size() - n, static_cast<uInt>(n));
  }
  band->deflated.resize(deflateBound(&z, input.size()) + 16);
  z.next_in = input.data();
  size_t produced = 0;
  size_t left = input.size();
  const int flush = last ? Z_FINISH : Z_SYNC_FLUSH;
  while (band->zlib_error == Z_OK) {
    const uInt in_chunk = static_cast<uInt>(std::min<size_t>(left, 1u << 30));
    z.avail_in = in_chunk;
    if (band->deflated.size() - produced < 64) band->deflated.resize(band->deflated.size() * 2);
    z.next_out = reinterpret_cast<Bytef*>(band->deflated.data() + produced);
    z.avail_out = static_cast<uInt>(std::min<size_t>(band->deflated.size() - produced, 1u << 30));
    const uInt out_before = z.avail_out;
    const int rc = deflate(&z, in_chunk == left ? flush : Z_NO_FLUSH);
    produced += out_before - z.avail_out;
    left -= in_chunk - z.avail_in;
    if (rc == Z_STREAM_END) break;
    if (rc != Z_OK && rc != Z_BUF_ERROR) {
      band->zlib_error = rc;
      break;
    }
    // A sync flush is complete once deflate leaves output space unused.
    if (!last && left == 0 && z.avail_out > 0) break;
  }
  deflateEnd(&z);
  band->deflated.resize(produced);
}

void AppendU32(std::string* out, uint32_t v) {
  out->push_back(static_cast<char>(v >> 24));
  out->push_back(static_cast<char>(v >> 16));
  out->push_back(static_cast<char>(v >> 8));
  out->push_back(static_cast<char>(v));
}

void AppendChunk(std::string* png, const char type[4], std::string_view data) {
  AppendU32(png, static_cast<uint32_t>(data.size()));
  const size_t type_at = png->size();
  png->append(type, 4);
  png->append(data);
  const auto* typed = reinterpret_cast<const Bytef*>(png->data() + type_at);
  AppendU32(png, static_cast<uint32_t>(crc32_z(0, typed, 4 + data.size())));
}

absl::StatusOr<std::string> Encode(const Rows& rows, size_t value_count, const PngEncodeOptions& options) {
  // An int side is within PNG's 2^31 - 1; the product must not wrap.
  if (rows.width < 1 || rows.height < 1 ||
      value_count / 4 / static_cast<size_t>(rows.width) != static_cast<size_t>(rows.height) ||
      value_count != static_cast<size_t>(rows.width) * static_cast<size_t>(rows.height) * 4) {
    return absl::InvalidArgumentError(absl::StrCat("cannot encode a PNG of ", value_count, " values as a ",
                                                   rows.width, "x", rows.height, " RGBA image"));
  }
  const int rows_per_band =
      static_cast<int>(std::clamp<size_t>(options.band_bytes / rows.line(), 1, static_cast<size_t>(rows.height)));
  std::vector<Band> bands;
  for (int y = 0; y < rows.height; y += rows_per_band) {
    Band band;
    band.y0 = y;
    band.y1 = std::min(rows.height, y + rows_per_band);
    bands.push_back(std::move(band));
  }
  int threads = options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, std::min(kMaxThreads, static_cast<int>(bands.size())));
  {
    // Bands are taken in order by whoever is free, this thread included, so
    // a helper that cannot be started (no threads left) only costs time.
    std::atomic<size_t> next{0};
    const auto work = [&] {
      for (size_t b = next++; b < bands.size(); b = next++) DeflateBand(rows, b + 1 == bands.size(), &bands[b]);
    };
    std::vector<std::jthread> helpers;
    for (int t = 1; t < threads; ++t) {
      try {
        helpers.emplace_back(work);
      } catch (const std::system_error&) {
        break;
      }
    }
    work();
  }
  std::string stream;
  size_t total = 2 + 4;
  for (const Band& b : bands) {
    if (b.zlib_error != Z_OK) {
      return absl::InternalError(absl::StrCat("zlib failed to deflate rows ", b.y0, "..", b.y1 - 1, ": error ",
                                              b.zlib_error));
    }
    total += b.deflated.size();
  }
  stream.reserve(total);
  // RFC 1950 header: deflate with a 32 KiB window (0x78), FLEVEL 1 for
  // levels 2..5, and the check bits that make the pair a multiple of 31.
  static_assert(kPngCompressionLevel >= 2 && kPngCompressionLevel <= 5);
  stream.push_back(static_cast<char>(0x78));
  stream.push_back(static_cast<char>(0x5e));
  uLong adler = adler32_z(0, nullptr, 0);
  for (const Band& b : bands) {
    stream += b.deflated;
    adler = adler32_combine(adler, b.adler, static_cast<z_off_t>(b.length));
  }
  AppendU32(&stream, static_cast<uint32_t>(adler));

  std::string png("\x89PNG\r\n\x1a\n", 8);
  png.reserve(stream.size() + stream.size() / kIdatBytes * 12 + 64);
  std::string header;
  AppendU32(&header, static_cast<uint32_t>(rows.width));
  AppendU32(&header, static_cast<uint32_t>(rows.height));
  header.push_back(static_cast<char>(rows.sample_bytes * 8));  // bit depth
  header.push_back(6);                                         // colour type: RGBA
  header.append(3, '\0');                                      // deflate, adaptive filtering, no interlace
  AppendChunk(&png, "IHDR", header);
  for (size_t at = 0; at < stream.size(); at += kIdatBytes) {
    AppendChunk(&png, "IDAT", std::string_view(stream).substr(at, kIdatBytes));
  }
  AppendChunk(&png, "IEND", {});
  return png;
}

}  // namespace

absl::StatusOr<std::string> EncodePngRgba8(std::span<const uint8_t> pixels, int width, int height,
                                           const PngEncodeOptions& options) {
  return Encode({pixels.data(), width, height, 1}, pixels.size(), options);
}

absl::StatusOr<std::string> EncodePngRgba16(std::span<const uint16_t> pixels, int width, int height,
                                            const PngEncodeOptions& options) {
  return Encode({pixels.data(), width, height, 2}, pixels.size(), options);
}

}  // namespace impostor
