#include "sources/pixels.hpp"

#include <cstdint>
#include <cstring>
#include <map>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"

namespace dtflop::sources {

PixelLayout pixel_layout(const std::string& name) {
  static const std::map<std::string, PixelLayout> known = {
      {"Mono8", {PixelFormat::mono8, 8}},           {"Mono10", {PixelFormat::mono10, 10}},
      {"Mono12", {PixelFormat::mono12, 12}},        {"Mono14", {PixelFormat::mono14, 14}},
      {"Mono16", {PixelFormat::mono16, 16}},        {"Mono12Packed", {PixelFormat::mono12_packed, 12}},
      {"Mono12p", {PixelFormat::mono12p, 12}},      {"BayerRG8", {PixelFormat::bayer_rg8, 8}},
      {"BayerGR8", {PixelFormat::bayer_gr8, 8}},    {"BayerGB8", {PixelFormat::bayer_gb8, 8}},
      {"BayerBG8", {PixelFormat::bayer_bg8, 8}},    {"BayerRG10", {PixelFormat::bayer_rg16, 10}},
      {"BayerGR10", {PixelFormat::bayer_gr16, 10}}, {"BayerGB10", {PixelFormat::bayer_gb16, 10}},
      {"BayerBG10", {PixelFormat::bayer_bg16, 10}}, {"BayerRG12", {PixelFormat::bayer_rg16, 12}},
      {"BayerGR12", {PixelFormat::bayer_gr16, 12}}, {"BayerGB12", {PixelFormat::bayer_gb16, 12}},
      {"BayerBG12", {PixelFormat::bayer_bg16, 12}}, {"BayerRG16", {PixelFormat::bayer_rg16, 16}},
      {"BayerGR16", {PixelFormat::bayer_gr16, 16}}, {"BayerGB16", {PixelFormat::bayer_gb16, 16}},
      {"BayerBG16", {PixelFormat::bayer_bg16, 16}}};
  const auto it = known.find(name);
  return it == known.end() ? PixelLayout{} : it->second;
}

std::size_t image_bytes(const PixelLayout& l, int width, int height) {
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  switch (l.format) {
    case PixelFormat::mono8:
    case PixelFormat::bayer_rg8:
    case PixelFormat::bayer_gr8:
    case PixelFormat::bayer_gb8:
    case PixelFormat::bayer_bg8: return n;
    case PixelFormat::mono12_packed:
    case PixelFormat::mono12p: return (n * 3 + 1) / 2;
    case PixelFormat::unsupported: return 0;
    default: return 2 * n;
  }
}

namespace {

// OpenCV names Bayer patterns by the second row's first two pixels; GenICam by the first row's.
int bayer_code(PixelFormat f) {
  switch (f) {
    case PixelFormat::bayer_rg8:
    case PixelFormat::bayer_rg16: return cv::COLOR_BayerBG2GRAY;
    case PixelFormat::bayer_gr8:
    case PixelFormat::bayer_gr16: return cv::COLOR_BayerGB2GRAY;
    case PixelFormat::bayer_gb8:
    case PixelFormat::bayer_gb16: return cv::COLOR_BayerGR2GRAY;
    default: return cv::COLOR_BayerRG2GRAY;  // bayer_bg
  }
}

bool is_bayer(PixelFormat f) {
  return f >= PixelFormat::bayer_rg8 && f <= PixelFormat::bayer_bg16;
}

}  // namespace

cv::Mat to_grey(const void* data, std::size_t size, int width, int height, const PixelLayout& l) {
  if (l.format == PixelFormat::unsupported)
    throw InputError("the camera's pixel format is not one dtflop reads; set format=Mono8, Mono12, Mono16 or a "
                     "Bayer format in the source");
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw InputError(fmt::format("a {}x{} frame is outside 1..16384 px a side; set a smaller ROI", width, height));
  const std::size_t want = image_bytes(l, width, height);
  if (size != want)
    throw InputError(fmt::format("a {}x{} frame of {}-bit pixels needs {} bytes and the source gave {}; the camera "
                                 "sent a damaged or differently-formatted frame: check its pixel format",
                                 width, height, l.bits, want, size));
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (l.format == PixelFormat::mono8)
    return cv::Mat(height, width, CV_8UC1, const_cast<std::uint8_t*>(bytes)).clone();
  if (l.bits == 8) {  // Bayer 8
    cv::Mat raw(height, width, CV_8UC1, const_cast<std::uint8_t*>(bytes));
    cv::Mat grey;
    cv::cvtColor(raw, grey, bayer_code(l.format));
    return grey;
  }
  cv::Mat out(height, width, CV_16UC1);
  auto* dst = out.ptr<std::uint16_t>();
  const int shift = 16 - l.bits;
  if (l.format == PixelFormat::mono12_packed || l.format == PixelFormat::mono12p) {
    // Two pixels in three bytes. Mono12Packed (GigE Vision): b0 = p0[11:4], b1 = p1[3:0]<<4 | p0[3:0],
    // b2 = p1[11:4]. Mono12p (PFNC): b0 = p0[7:0], b1 = p1[3:0]<<4 | p0[11:8], b2 = p1[11:4].
    const bool gev = l.format == PixelFormat::mono12_packed;
    for (std::size_t i = 0; i < n; i += 2) {
      const std::uint8_t* b = bytes + (i / 2) * 3;
      const unsigned p0 = gev ? (unsigned{b[0]} << 4) | (b[1] & 0x0Fu) : unsigned{b[0]} | ((b[1] & 0x0Fu) << 8);
      dst[i] = static_cast<std::uint16_t>(p0 << shift);
      if (i + 1 < n) {
        const unsigned p1 = (unsigned{b[2]} << 4) | (b[1] >> 4);
        dst[i + 1] = static_cast<std::uint16_t>(p1 << shift);
      }
    }
    return out;
  }
  // 16-bit little-endian containers; bits above the significant ones are masked off.
  const unsigned mask = (1u << l.bits) - 1u;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned v = (unsigned{bytes[2 * i]} | (unsigned{bytes[2 * i + 1]} << 8)) & mask;
    dst[i] = static_cast<std::uint16_t>(v << shift);
  }
  if (is_bayer(l.format)) {
    cv::Mat grey;
    cv::cvtColor(out, grey, bayer_code(l.format));
    return grey;
  }
  return out;
}

}  // namespace dtflop::sources
