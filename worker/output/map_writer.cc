#include "worker/output/map_writer.h"

#include <OpenImageIO/imageio.h>

#include <memory>
#include <string>
#include <system_error>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

absl::Status WritePng(const std::filesystem::path& path, const void* pixels, size_t count,
                      int width, int height, OIIO::TypeDesc format) {
  if (width < 1 || height < 1 || count != static_cast<size_t>(width) * height * 4) {
    return absl::InvalidArgumentError(absl::StrCat("cannot write '", path.string(), "': ", count,
                                                   " values for a ", width, "x", height,
                                                   " RGBA image"));
  }
  const std::string name = path.string();
  // Ask for the PNG writer explicitly: the file name need not end in .png
  // (the worker writes to temporary names).
  std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create("png");
  if (!out) {
    return absl::InternalError(absl::StrCat("OpenImageIO has no PNG writer: ", OIIO::geterror()));
  }
  OIIO::ImageSpec spec(width, height, 4, format);
  // Our fourth channel is coverage or depth, not associated alpha: without
  // this OIIO divides RGB by A on write.
  spec.attribute("oiio:UnassociatedAlpha", 1);
  spec.attribute("png:compressionLevel", kPngCompressionLevel);
  spec.attribute("png:filter", kPngRowFilter);
  if (!out->open(name, spec)) {
    return absl::InternalError(absl::StrCat("cannot create '", name, "': ", out->geterror()));
  }
  if (!out->write_image(format, pixels)) {
    const std::string error = out->geterror();
    out->close();
    return absl::InternalError(absl::StrCat("cannot write '", name, "': ", error));
  }
  if (!out->close()) {
    return absl::InternalError(absl::StrCat("cannot finish '", name, "': ", out->geterror()));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status WritePngRgba8(const std::filesystem::path& path, std::span<const uint8_t> pixels,
                           int width, int height) {
  return WritePng(path, pixels.data(), pixels.size(), width, height, OIIO::TypeDesc::UINT8);
}

absl::Status WritePngRgba16(const std::filesystem::path& path, std::span<const uint16_t> pixels,
                            int width, int height) {
  return WritePng(path, pixels.data(), pixels.size(), width, height, OIIO::TypeDesc::UINT16);
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
