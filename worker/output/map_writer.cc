#include "worker/output/map_writer.h"

#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <memory>
#include <string>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "worker/output/png_encoder.h"

namespace impostor {
namespace {

// Writes the encoded bytes to `path` (created or truncated). Errors name
// the file and the system's reason (a full disk says so).
absl::Status WriteFileBytes(const std::filesystem::path& path, const absl::StatusOr<std::string>& png) {
  if (!png.ok()) {
    return absl::Status(png.status().code(), absl::StrCat("cannot write '", path.string(), "': ", png.status().message()));
  }
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return absl::InternalError(absl::StrCat("cannot create '", path.string(), "': ", std::strerror(errno)));
  size_t written = 0;
  while (written < png->size()) {
    const ssize_t n = ::write(fd, png->data() + written, png->size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = n < 0 ? errno : EIO;
      ::close(fd);
      return absl::InternalError(absl::StrCat("cannot write '", path.string(), "': ", std::strerror(error)));
    }
    written += static_cast<size_t>(n);
  }
  if (::close(fd) != 0) {
    return absl::InternalError(absl::StrCat("cannot finish '", path.string(), "': ", std::strerror(errno)));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status WritePngRgba8(const std::filesystem::path& path, std::span<const uint8_t> pixels,
                           int width, int height) {
  return WriteFileBytes(path, EncodePngRgba8(pixels, width, height));
}

absl::Status WritePngRgba16(const std::filesystem::path& path, std::span<const uint16_t> pixels,
                            int width, int height) {
  return WriteFileBytes(path, EncodePngRgba16(pixels, width, height));
}

absl::StatusOr<PngImage> ReadPng(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat("'", path.string(), "' does not exist"));
  }
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);  // no premultiplication on read
  std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path.string(), &config);
  if (!in) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot open '", path.string(), "': ", OIIO::geterror()));
  }
  const OIIO::ImageSpec& spec = in->spec();
  if (std::string(in->format_name()) != "png") {
    return absl::InvalidArgumentError(
        absl::StrCat("'", path.string(), "' is ", in->format_name(), ", not PNG"));
  }
  PngImage image;
  image.width = spec.width;
  image.height = spec.height;
  image.channels = spec.nchannels;
  const size_t count = static_cast<size_t>(spec.width) * spec.height * spec.nchannels;
  bool ok = false;
  if (spec.format == OIIO::TypeDesc::UINT8) {
    image.bit_depth = 8;
    image.pixels8.resize(count);
    ok = in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, image.pixels8.data());
  } else if (spec.format == OIIO::TypeDesc::UINT16) {
    image.bit_depth = 16;
    image.pixels16.resize(count);
    ok = in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT16, image.pixels16.data());
  } else {
    return absl::InvalidArgumentError(absl::StrCat("'", path.string(), "' has pixel format ",
                                                   spec.format.c_str(), ", not 8/16-bit"));
  }
  if (!ok) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot read '", path.string(), "': ", in->geterror()));
  }
  return image;
}

}  // namespace impostor
