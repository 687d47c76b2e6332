#include "workloads/dct/io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <optional>
#include <string_view>
#include <utility>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "workloads/dct/fields.hpp"

namespace dtflop::dct {

namespace {

// Refuses an image whose declared size exceeds what dtflop processes, before it is decoded (a
// header may declare 100000x100000 in a few bytes); the decoded result is checked again.
void check_image_size(const std::filesystem::path& path, std::int64_t w, std::int64_t h) {
  if (w < 1 || h < 1 || w > kMaxImageSide || h > kMaxImageSide || w * h > kMaxImagePixels)
    throw InputError(fmt::format("image '{}' is {}x{} px (about {:.0f} MiB as 16-bit grey): outside 1..{} px a side "
                                 "and {} MP; use a smaller image or a --roi of it",
                                 path.string(), w, h, static_cast<double>(w) * static_cast<double>(h) * 2 / (1 << 20), kMaxImageSide, kMaxImagePixels / 1000000));
}

// The size an image's header declares, for each format check_format lets through; nullopt where
// the header cannot be read (the file is then refused as damaged). OpenCV allocates the declared
// size before it reads a pixel, so a 20-byte PPM declaring 8577x85777 took 2.2 GB (fuzz_image).
std::optional<std::pair<std::int64_t, std::int64_t>> declared_size(const std::string& bytes) {
  const std::size_t n = bytes.size();
  auto u8 = [&](std::size_t at) -> std::int64_t { return static_cast<unsigned char>(bytes[at]); };
  auto be = [&](std::size_t at, std::size_t len) {
    std::int64_t v = 0;
    for (std::size_t i = 0; i < len; ++i) v = (v << 8) | u8(at + i);
    return v;
  };
  auto le = [&](std::size_t at, std::size_t len) {
    std::int64_t v = 0;
    for (std::size_t i = len; i-- > 0;) v = (v << 8) | u8(at + i);
    return v;
  };
  using Size = std::pair<std::int64_t, std::int64_t>;
  if (bytes.compare(0, 4, "\x89PNG") == 0) {  // IHDR: width, height
    if (n < 24) return std::nullopt;
    return Size{be(16, 4), be(20, 4)};
  }
  if (bytes.compare(0, 2, "BM") == 0) {  // BITMAPCOREHEADER (12 bytes): 16-bit sizes; later ones 32-bit
    if (n < 26) return std::nullopt;
    if (le(14, 4) == 12) return Size{le(18, 2), le(20, 2)};
    const auto s32 = [&](std::size_t at) { return static_cast<std::int64_t>(static_cast<std::int32_t>(le(at, 4))); };
    return Size{s32(18), std::abs(s32(22))};  // a negative height is a top-down image
  }
  if (bytes[0] == 'P') {  // PNM: magic, then width and height in decimal, with # comments
    std::size_t at = 2;
    auto number = [&]() -> std::optional<std::int64_t> {
      for (;;) {
        while (at < n && std::string_view(" \t\n\v\f\r").find(bytes[at]) != std::string_view::npos) ++at;
        if (at < n && bytes[at] == '#') {
          while (at < n && bytes[at] != '\n' && bytes[at] != '\r') ++at;
          continue;
        }
        break;
      }
      std::int64_t v = 0;
      const std::size_t first = at;
      while (at < n && bytes[at] >= '0' && bytes[at] <= '9') {
        v = std::min<std::int64_t>(v * 10 + (bytes[at] - '0'), std::int64_t{1} << 40);  // no overflow
        ++at;
      }
      if (at == first) return std::nullopt;
      // A number ends at whitespace: OpenCV's reader takes "766#6666..." otherwise than this one
      // (it allocated 3 GB for "P6 766#666666*6666 7"), so such a header is refused as damaged.
      if (at < n && std::string_view(" \t\n\v\f\r").find(bytes[at]) == std::string_view::npos) return std::nullopt;
      return v;
    };
    const auto w = number();
    const auto h = w ? number() : std::nullopt;
    if (!h) return std::nullopt;
    return Size{*w, *h};
  }
  if (bytes.compare(0, 2, "\xff\xd8") == 0) {  // JPEG: the first start-of-frame marker's height, width
    std::size_t at = 2;
    while (at + 4 <= n) {
      if (u8(at) != 0xff) return std::nullopt;
      const std::int64_t m = u8(at + 1);
      if (m == 0xff) {  // fill byte
        ++at;
        continue;
      }
      if (m == 0x01 || (m >= 0xd0 && m <= 0xd7)) {  // markers without a length
        at += 2;
        continue;
      }
      if (m == 0xd9 || m == 0xda) return std::nullopt;  // end of image or start of scan before a frame
      const bool sof = m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc;
      if (sof) {
        if (at + 9 > n) return std::nullopt;
        return Size{be(at + 7, 2), be(at + 5, 2)};
      }
      at += 2 + static_cast<std::size_t>(be(at + 2, 2));
    }
    return std::nullopt;
  }
  // TIFF: ImageWidth (256) and ImageLength (257) in the first IFD, SHORT or LONG, in the file's
  // byte order.
  if (n < 8) return std::nullopt;
  const bool little = bytes[0] == 'I';
  auto get = [&](std::size_t at, std::size_t len) { return little ? le(at, len) : be(at, len); };
  const auto ifd = static_cast<std::size_t>(get(4, 4));
  if (ifd > n || n - ifd < 2) return std::nullopt;
  const auto entries = static_cast<std::size_t>(get(ifd, 2));
  std::int64_t w = -1, h = -1;
  for (std::size_t i = 0; i < entries && ifd + 2 + 12 * (i + 1) <= n; ++i) {
    const std::size_t e = ifd + 2 + 12 * i;
    const std::int64_t tag = get(e, 2), type = get(e + 2, 2);
    if (tag != 256 && tag != 257) continue;
    const std::int64_t v = type == 3 ? get(e + 8, 2) : type == 4 ? get(e + 8, 4) : -1;
    (tag == 256 ? w : h) = v;
  }
  if (w < 0 || h < 0) return std::nullopt;
  return Size{w, h};
}

// Only the still formats a camera or dtflop writes are decoded: PNG, TIFF, JPEG, BMP and PGM/PPM,
// told by their first bytes. OpenCV picks a decoder by signature among many more (DICOM, JPEG 2000,
// OpenEXR, HDR, ...), and some of those libraries abort the process on damaged input (GDCM
// asserts on a file with "DICM" at byte 128), so nothing else reaches them. A PGM/PPM magic number
// must be followed by white space as the format says: OpenCV's own check wants it, and without
// it a "P5" file with "DICM" at byte 128 still went to GDCM.
void check_format(const std::filesystem::path& path, const std::string& bytes) {
  auto starts = [&](std::string_view sig) { return bytes.compare(0, sig.size(), sig) == 0; };
  using namespace std::string_view_literals;
  const bool known = starts("\x89PNG\r\n\x1a\n"sv) || starts("II*\0"sv) || starts("MM\0*"sv) ||
                     starts("\xff\xd8\xff"sv) || starts("BM"sv) ||
                     (bytes.size() >= 3 && bytes[0] == 'P' && bytes[1] >= '1' && bytes[1] <= '6' &&
                      std::string_view(" \t\n\v\f\r").find(bytes[2]) != std::string_view::npos);
  if (!known)
    throw InputError(fmt::format("image '{}' is not a PNG, TIFF, JPEG, BMP or PGM/PPM file (judged by its first "
                                 "bytes); convert it to PNG or TIFF",
                                 path.string()));
}

}  // namespace

cv::Mat read_grey(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(fmt::format("image '{}' does not exist or is not a file", path.string()));
  return decode_grey(read_file_limited(path, fmt::format("image '{}'", path.string()), kMaxImageFileBytes), path);
}

cv::Mat decode_grey(const std::string& bytes, const std::filesystem::path& path) {
  if (bytes.empty() || bytes.size() > kMaxImageFileBytes)
    throw InputError(fmt::format("image '{}' is empty or larger than 1 GiB", path.string()));
  check_format(path, bytes);
  // A header that does not say the size as its format does is refused, not left to OpenCV, whose
  // readers are laxer ("P6 8554& 85777" still allocated 2.2 GB).
  const auto size = declared_size(bytes);
  if (!size)
    throw InputError(fmt::format("image '{}' is damaged: its header does not give its width and height as its format "
                                 "says; use an undamaged image",
                                 path.string()));
  check_image_size(path, size->first, size->second);
  cv::Mat img;
  try {
    img = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data())),
                       cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("image '{}' cannot be decoded ({}); use an image of at most {} MP", path.string(),
                                 e.err, kMaxImagePixels / 1000000));
  }
  if (!img.empty()) check_image_size(path, img.cols, img.rows);
  if (img.empty())
    throw InputError(fmt::format("image '{}' cannot be read: not an image format OpenCV knows, or damaged",
                                 path.string()));
  if (img.depth() != CV_8U && img.depth() != CV_16U)
    throw InputError(fmt::format("image '{}' has an unsupported depth; use 8- or 16-bit images", path.string()));
  if (img.channels() == 3) cv::cvtColor(img, img, cv::COLOR_BGR2GRAY);
  else if (img.channels() == 4) cv::cvtColor(img, img, cv::COLOR_BGRA2GRAY);
  else if (img.channels() != 1)
    throw InputError(fmt::format("image '{}' has {} channels; use grey or colour images", path.string(), img.channels()));
  return img;
}

void write_image(const std::filesystem::path& path, const cv::Mat& image) {
  if (path.has_parent_path()) make_output_folder(path.parent_path(), fmt::format("image '{}'", path.string()));
  // Encoded in memory, then written by the one output path (atomic, never over a link or device).
  std::vector<std::uint8_t> bytes;
  bool ok = false;
  try {
    ok = cv::imencode(path.extension().string(), image, bytes);
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("cannot write image '{}': {}", path.string(), e.err));
  }
  if (!ok) throw InputError(fmt::format("cannot write image '{}' (unknown extension)", path.string()));
  write_file_atomically(path, std::string(bytes.begin(), bytes.end()));
}

namespace {
// A finite value with `digits` significant digits, or nothing.
std::string num_or_empty(double v, double scale = 1) {
  return std::isfinite(v) ? fmt::format("{:.4g}", v * scale) : std::string();
}
}  // namespace

void write_fields_csv(const std::filesystem::path& path, const std::vector<Vec2>& points,
                      const std::vector<FieldValue<double>>& fields, const std::vector<FieldSigma>& sigma) {
  if (points.size() != fields.size()) throw InputError("points and fields differ in length");
  if (!sigma.empty() && sigma.size() != fields.size()) throw InputError("points and deviations differ in length");
  if (path.has_parent_path()) make_output_folder(path.parent_path(), fmt::format("'{}'", path.string()));
  // One unit everywhere dtflop shows a field: px for positions and displacements, microstrain for
  // strains (kCsvHeader names them).
  std::string f = std::string(kCsvHeader) + "\n";
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& v = fields[i];
    const bool ok = v.status == PointStatus::ok;
    if (ok)
      f += fmt::format("{:.3f},{:.3f},{:.6f},{:.6f},{:.6g},{:.6g},{:.6g},1,ok,{}", points[i].x, points[i].y, v.ux,
                       v.uy, v.exx * 1e6, v.eyy * 1e6, v.exy * 1e6, v.support);
    else
      f += fmt::format("{:.3f},{:.3f},,,,,,0,{},{}", points[i].x, points[i].y, to_string(v.status), v.support);
    if (ok && !sigma.empty()) {
      const FieldSigma& s = sigma[i];
      f += fmt::format(",{},{},{},{},{}\n", num_or_empty(s.ux), num_or_empty(s.uy), num_or_empty(s.exx, 1e6),
                       num_or_empty(s.eyy, 1e6), num_or_empty(s.exy, 1e6));
    } else {
      f += ",,,,,\n";
    }
  }
  write_file_atomically(path, f);
}

void write_dots_csv(const std::filesystem::path& path, const std::vector<DotObservation>& reference,
                    const std::vector<DotObservation>& frame, const Matches& matches, const cv::Mat& frame_image,
                    double threshold, Polarity polarity, const FrameUncertainty* uncertainty) {
  if (matches.ref_to_def.size() != reference.size()) throw InputError("the matches do not fit the reference dots");
  if (path.has_parent_path()) make_output_folder(path.parent_path(), fmt::format("'{}'", path.string()));
  const bool dark = polarity == Polarity::dark_dots;
  auto mean_intensity = [&](const DotObservation& d) -> std::string {
    if (threshold < 0 || frame_image.empty()) return {};
    const cv::Rect box = d.box & cv::Rect(0, 0, frame_image.cols, frame_image.rows);
    double sum = 0;
    long n = 0;
    for (int y = box.y; y < box.y + box.height; ++y)
      for (int x = box.x; x < box.x + box.width; ++x) {
        const double v = frame_image.depth() == CV_16U ? frame_image.at<std::uint16_t>(y, x)
                                                       : frame_image.at<std::uint8_t>(y, x);
        if (dark ? v <= threshold : v > threshold) { sum += v; ++n; }
      }
    return n ? fmt::format("{:.2f}", sum / static_cast<double>(n)) : std::string();
  };
  auto sd = [&](const std::vector<CentroidSigma>* v, std::size_t k) -> std::string {
    if (!v || k >= v->size()) return {};
    const CentroidSigma& s = (*v)[k];
    return num_or_empty(std::sqrt(0.5 * (s.x * s.x + s.y * s.y)));
  };
  std::string f = std::string(kDotsCsvHeader) + "\n";
  for (std::size_t j = 0; j < reference.size(); ++j) {
    const DotObservation& r = reference[j];
    const int k = matches.ref_to_def[j];
    const std::string why = j < matches.lost_reason.size() && k < 0
                                ? (matches.lost_reason[j] == LostReason::ambiguous          ? "ambiguous"
                                   : matches.lost_reason[j] == LostReason::claimed_by_other ? "claimed_by_other"
                                                                                            : "nothing_near")
                                : "";
    f += fmt::format("{},{},{},{},{:.4f},{:.4f},{}", j, k >= 0 ? std::to_string(k) : "", k >= 0 ? "matched" : "lost",
                     why, r.x, r.y, r.area);
    if (k >= 0) {
      const DotObservation& d = frame[static_cast<std::size_t>(k)];
      f += fmt::format(",{:.4f},{:.4f},{},{:.5f},{:.5f},{}", d.x, d.y, d.area, d.x - r.x, d.y - r.y, mean_intensity(d));
    } else {
      f += ",,,,,,";
    }
    f += fmt::format(",{},{}\n", sd(uncertainty ? &uncertainty->reference_dots : nullptr, j),
                     k >= 0 ? sd(uncertainty ? &uncertainty->frame_dots : nullptr, static_cast<std::size_t>(k)) : "");
  }
  for (int k : matches.appeared) {
    const DotObservation& d = frame[static_cast<std::size_t>(k)];
    f += fmt::format(",{},appeared,unclaimed,,,,{:.4f},{:.4f},{},,,{},,{}\n", k, d.x, d.y, d.area, mean_intensity(d),
                     sd(uncertainty ? &uncertainty->frame_dots : nullptr, static_cast<std::size_t>(k)));
  }
  write_file_atomically(path, f);
}

std::string field_name(Field f) {
  switch (f) {
    case Field::ux: return "u_x";
    case Field::uy: return "u_y";
    case Field::exx: return "e_xx";
    case Field::eyy: return "e_yy";
    case Field::exy: return "e_xy";
  }
  return "?";
}
std::string field_unit(Field f) { return (f == Field::ux || f == Field::uy) ? "px" : "microstrain"; }
double field_value(const FieldValue<double>& v, Field f) {
  switch (f) {
    case Field::ux: return v.ux;
    case Field::uy: return v.uy;
    case Field::exx: return v.exx * 1e6;
    case Field::eyy: return v.eyy * 1e6;
    case Field::exy: return v.exy * 1e6;
  }
  return 0;
}

ColourRange colour_range(const std::vector<double>& values) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double v : values)
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  if (!std::isfinite(lo)) return {-1, 1, false};
  if (lo < 0 && hi > 0) {  // signed: symmetric about zero, so zero is the diverging map's middle
    hi = std::max(-lo, hi);
    lo = -hi;
  }
  if (hi - lo < 1e-12 * std::max(1.0, std::abs(hi))) {
    const double pad = std::max(0.5, 0.05 * std::abs(hi));
    hi += pad;
    lo -= pad;
  }
  return {lo, hi, true};
}

ColourRange parse_colour_range(const std::string& text, const std::string& option) {
  const auto colon = text.find(':');
  double lo = 0, hi = 0;
  bool ok = colon != std::string::npos;
  if (ok) {
    try {
      std::size_t a = 0, b = 0;
      lo = std::stod(text.substr(0, colon), &a);
      hi = std::stod(text.substr(colon + 1), &b);
      ok = a == colon && b == text.size() - colon - 1;
    } catch (const std::exception&) {
      ok = false;
    }
  }
  if (!ok || !std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi))
    throw InputError(fmt::format("{} '{}' is not LO:HI with finite LO < HI, e.g. -500:500", option, text.substr(0, 60)));
  return {lo, hi, true};
}

std::vector<double> nice_ticks(double lo, double hi, int most) {
  if (!(lo < hi) || most < 2) return {lo, hi};
  const double raw = (hi - lo) / (most - 1);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  std::vector<double> out;
  // k x step, rounded to 12 significant digits: 0.6, not 0.6000000000000001, on a label.
  for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + 1e-9 * step; k += 1)
    out.push_back(k == 0 ? 0.0 : std::stod(fmt::format("{:.12g}", k * step)));
  return out;
}

namespace {

// 256-entry colour maps (BGR). Signed fields: a diverging blue - light grey - red map
// (Moreland's "cool to warm" end and middle points, interpolated in CIE L*a*b* so equal steps
// of value look like equal steps of colour); one-signed fields: viridis (OpenCV's).
cv::Mat diverging_lut() {
  static const cv::Mat lut = [] {
    const cv::Vec3f ends[3] = {{59, 76, 192}, {221, 221, 221}, {180, 4, 38}};  // RGB, 0..255
    cv::Mat rgb(1, 3, CV_32FC3), lab;
    for (int i = 0; i < 3; ++i) rgb.at<cv::Vec3f>(0, i) = ends[i] / 255.f;
    cv::cvtColor(rgb, lab, cv::COLOR_RGB2Lab);
    cv::Mat steps(256, 1, CV_32FC3);  // applyColorMap takes a 256 x 1 table
    for (int i = 0; i < 256; ++i) {
      const float t = i / 255.f * 2;
      const int k = std::min(1, static_cast<int>(t));
      const float f = t - k;
      steps.at<cv::Vec3f>(i, 0) = lab.at<cv::Vec3f>(0, k) * (1 - f) + lab.at<cv::Vec3f>(0, k + 1) * f;
    }
    cv::Mat back, out;
    cv::cvtColor(steps, back, cv::COLOR_Lab2BGR);
    back.convertTo(out, CV_8UC3, 255.0);
    return out;
  }();
  return lut;
}

void colourize(const cv::Mat& index, bool diverging, cv::Mat& out) {
  if (diverging) cv::applyColorMap(index, out, diverging_lut());
  else cv::applyColorMap(index, out, cv::COLORMAP_VIRIDIS);
}

}  // namespace

cv::Mat overlay(const cv::Mat& image, const std::vector<Vec2>& points, int nx, int ny, const std::vector<double>& values,
                const std::string& title, const std::string& unit, std::optional<ColourRange> range) {
  if (nx < 2 || ny < 2 || static_cast<std::size_t>(nx) * ny != points.size() || values.size() != points.size())
    throw InputError("an overlay needs a grid of at least 2x2 points with one value each");
  cv::Mat grey8;
  if (image.depth() == CV_16U) image.convertTo(grey8, CV_8U, 1.0 / 257);
  else grey8 = image;
  cv::Mat base;
  cv::cvtColor(grey8, base, cv::COLOR_GRAY2BGR);
  const ColourRange r = range ? *range : colour_range(values);
  const double lo = r.lo, hi = r.hi;
  const bool diverging = lo < 0 && hi > 0;
  // Field on the point grid (8-bit colour index + validity), resized over the grid's extent.
  cv::Mat idx(ny, nx, CV_8U), valid(ny, nx, CV_8U);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double v = values[static_cast<std::size_t>(j) * nx + i];
      valid.at<std::uint8_t>(j, i) = std::isfinite(v) ? 255 : 0;
      idx.at<std::uint8_t>(j, i) =
          std::isfinite(v) ? cv::saturate_cast<std::uint8_t>(255 * std::clamp((v - lo) / (hi - lo), 0.0, 1.0)) : 0;
    }
  const double x0 = points.front().x, y0 = points.front().y, x1 = points.back().x, y1 = points.back().y;
  const cv::Rect area = cv::Rect(cv::Point(static_cast<int>(std::floor(x0)), static_cast<int>(std::floor(y0))),
                                 cv::Point(static_cast<int>(std::ceil(x1)) + 1, static_cast<int>(std::ceil(y1)) + 1)) &
                        cv::Rect(0, 0, base.cols, base.rows);
  if (area.area() > 0) {
    cv::Mat big, bigvalid, mask, colour;
    cv::resize(idx, big, area.size(), 0, 0, cv::INTER_LINEAR);
    // A pixel is painted only where every point around it is valid: a hole or an edge without
    // valid points stays the image, following the point grid rather than a blocky square.
    cv::resize(valid, bigvalid, area.size(), 0, 0, cv::INTER_LINEAR);
    cv::threshold(bigvalid, mask, 254, 255, cv::THRESH_BINARY);
    colourize(big, diverging, colour);
    cv::Mat roi = base(area), blend;
    cv::addWeighted(roi, 0.35, colour, 0.65, 0, blend);
    blend.copyTo(roi, mask);
  }
  // Colour bar on the right: the title and unit above it, ticks at round values.
  const double scale = std::max(0.45, base.rows / 1200.0);
  const int thick = std::max(1, static_cast<int>(scale * 1.5));
  const auto ticks = nice_ticks(lo, hi, 7);
  auto label = [](double t) { return fmt::format("{:g}", t); };
  const std::string head = fmt::format("{} [{}]", title, unit);
  int baseline = 0;
  int text_w = cv::getTextSize(head, cv::FONT_HERSHEY_SIMPLEX, scale, thick, &baseline).width;
  const int text_h = cv::getTextSize("0", cv::FONT_HERSHEY_SIMPLEX, scale, thick, &baseline).height;
  const int ramp_w = std::max(20, base.cols / 40), pad = 12;
  int tick_w = 0;
  for (double t : ticks)
    tick_w = std::max(tick_w, cv::getTextSize(label(t), cv::FONT_HERSHEY_SIMPLEX, scale, thick, &baseline).width);
  const int panel = std::max(text_w, ramp_w + 8 + tick_w) + 2 * pad;
  cv::Mat canvas(base.rows, base.cols + panel, CV_8UC3, cv::Scalar(255, 255, 255));
  base.copyTo(canvas(cv::Rect(0, 0, base.cols, base.rows)));
  const int bx = base.cols + pad, by = 2 * text_h + 2 * pad;
  const int bar_h = std::max(64, base.rows - by - pad - text_h);
  cv::Mat ramp(bar_h, 1, CV_8U);
  for (int i = 0; i < bar_h; ++i) ramp.at<std::uint8_t>(i, 0) = static_cast<std::uint8_t>(255 - (255 * i) / (bar_h - 1));
  cv::Mat ramp_c, ramp_big;
  colourize(ramp, diverging, ramp_c);
  cv::resize(ramp_c, ramp_big, cv::Size(ramp_w, bar_h), 0, 0, cv::INTER_NEAREST);
  ramp_big.copyTo(canvas(cv::Rect(bx, by, ramp_big.cols, ramp_big.rows)));
  auto text = [&](const std::string& s, int x, int y) {
    cv::putText(canvas, s, cv::Point(x, y), cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), thick, cv::LINE_AA);
  };
  text(head, base.cols + pad, pad + text_h);
  for (double t : ticks) {
    const int y = by + static_cast<int>(std::lround((hi - t) / (hi - lo) * (bar_h - 1)));
    cv::line(canvas, {bx + ramp_w, y}, {bx + ramp_w + 5, y}, cv::Scalar(0, 0, 0), 1);
    text(label(t), bx + ramp_w + 8, y + text_h / 2);
  }
  return canvas;
}

}  // namespace dtflop::dct
