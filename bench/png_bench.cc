// png_bench: the maps' PNG encoding, libpng through OpenImageIO (one
// thread, what the worker used before worker/output/png_encoder.h) against
// the banded encoder at 1, 2 and all hardware threads, on real maps. Not a
// test: prints figures (median of --repeat runs), ratios within one run.
//
//   png_bench [--repeat N] MAP.png ...
//
// Maps come from a kept bake, e.g. `bake_stages --quality-views 0 --keep
// DIR` then `png_bench DIR/albedo_alpha.png DIR/normal_depth.png DIR/orm.png`.
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "bench/bench_args.h"
#include "bench/median_time.h"
#include "worker/output/map_writer.h"
#include "worker/output/png_encoder.h"

namespace fs = std::filesystem;

namespace {

// The worker's writer before the banded encoder: OpenImageIO's PNG output
// with the same level and row filter. Returns the file's size.
size_t WriteWithOiio(const fs::path& path, const impostor::PngImage& image) {
  const OIIO::TypeDesc format = image.bit_depth == 16 ? OIIO::TypeDesc::UINT16 : OIIO::TypeDesc::UINT8;
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create("png");
  OIIO::ImageSpec spec(image.width, image.height, 4, format);
  spec.attribute("oiio:UnassociatedAlpha", 1);
  spec.attribute("png:compressionLevel", impostor::kPngCompressionLevel);
  spec.attribute("png:filter", impostor::kPngRowFilter);
  const void* pixels = image.bit_depth == 16 ? static_cast<const void*>(image.pixels16.data())
                                             : static_cast<const void*>(image.pixels8.data());
  if (!out || !out->open(path.string(), spec) || !out->write_image(format, pixels) || !out->close()) return 0;
  return fs::file_size(path);
}

size_t EncodeBanded(const impostor::PngImage& image, int threads) {
  const impostor::PngEncodeOptions options{.threads = threads};
  const absl::StatusOr<std::string> png =
      image.bit_depth == 16 ? impostor::EncodePngRgba16(image.pixels16, image.width, image.height, options)
                            : impostor::EncodePngRgba8(image.pixels8, image.width, image.height, options);
  return png.ok() ? png->size() : 0;
}

template <typename F>
double MedianMs(int repeat, F run) {
  return 1000.0 * impostor::bench::MedianSeconds(repeat, run);
}

}  // namespace

int main(int argc, char** argv) {
  int repeat = 3;
  std::vector<std::string> files;
  impostor::bench::BenchArgs("png_bench", "PNG encoding of real maps: OpenImageIO against the banded encoder.")
      .Int("--repeat", &repeat, "runs of each encoding; the median is printed (default 3)")
      .Positional("MAP.png", &files, "maps to re-encode (RGBA, 8 or 16 bits)")
      .ParseOrExit(argc, argv);
  if (files.empty() || repeat < 1) {
    std::fprintf(stderr, "png_bench: give at least one MAP.png (and --repeat >= 1); --help says more\n");
    return 2;
  }
  const int hardware = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const fs::path scratch = fs::temp_directory_path() / ("png_bench_" + std::to_string(::getpid()) + ".png");
  std::printf("png_bench: median of %d runs, %d hardware threads\n", repeat, hardware);
  std::printf("%-22s %6s %10s %10s %10s %10s %10s %8s %8s\n", "map", "bits", "oiio_ms", "band1_ms", "band2_ms",
              "bandN_ms", "oiio_MB", "band_MB", "oiio/N");
  double total_oiio = 0, total_n = 0;
  for (const std::string& file : files) {
    const absl::StatusOr<impostor::PngImage> image = impostor::ReadPng(file);
    if (!image.ok() || image->channels != 4) {
      std::fprintf(stderr, "png_bench: %s: %s\n", file.c_str(),
                   image.ok() ? "not RGBA" : std::string(image.status().message()).c_str());
      return 1;
    }
    size_t oiio_bytes = 0, banded_bytes = 0;
    const double oiio = MedianMs(repeat, [&] { oiio_bytes = WriteWithOiio(scratch, *image); });
    const double one = MedianMs(repeat, [&] { banded_bytes = EncodeBanded(*image, 1); });
    const double two = MedianMs(repeat, [&] { EncodeBanded(*image, 2); });
    const double all = MedianMs(repeat, [&] { EncodeBanded(*image, hardware); });
    total_oiio += oiio;
    total_n += all;
    std::printf("%-22s %6d %10.1f %10.1f %10.1f %10.1f %10.2f %8.2f %8.2f\n", fs::path(file).filename().c_str(),
                image->bit_depth, oiio, one, two, all, oiio_bytes / 1e6, banded_bytes / 1e6, oiio / all);
  }
  fs::remove(scratch);
  std::printf("all maps: OpenImageIO %.1f ms, banded on %d threads %.1f ms (%.2fx)\n", total_oiio, hardware, total_n,
              total_oiio / total_n);
  return 0;
}
