// Camera pixel formats to the grey images the DCT workload reads, without losing bit depth.
#pragma once

#include <cstddef>
#include <string>

#include <opencv2/core.hpp>

namespace dtflop::sources {

// The GenICam (PFNC) formats dtflop turns into grey: monochrome and Bayer, 8 bits or 10/12/14/16
// bits in 16-bit little-endian containers (unpacked), and Mono12Packed / Mono12p.
enum class PixelFormat {
  mono8, mono10, mono12, mono14, mono16, mono12_packed, mono12p,
  bayer_rg8, bayer_gr8, bayer_gb8, bayer_bg8,
  bayer_rg16, bayer_gr16, bayer_gb16, bayer_bg16,  // 10, 12 or 16 significant bits (see bits)
  unsupported
};

struct PixelLayout {
  PixelFormat format = PixelFormat::unsupported;
  int bits = 8;  // significant bits per pixel
};

// By GenICam name ("Mono12", "BayerRG12", "Mono12Packed", ...); format unsupported when unknown.
PixelLayout pixel_layout(const std::string& name);

// Bytes one w x h image of `layout` takes.
std::size_t image_bytes(const PixelLayout& layout, int width, int height);

// Grey image of `width` x `height` from `size` bytes of `layout`: CV_8U for 8-bit formats, else
// CV_16U with the significant bits at the top of the 16 (a 12-bit 4095 becomes 65520). Bayer is
// demosaiced to grey at the source depth. Throws InputError when `size` is not what the format
// and size need, or the format is unsupported.
cv::Mat to_grey(const void* data, std::size_t size, int width, int height, const PixelLayout& layout);

}  // namespace dtflop::sources
