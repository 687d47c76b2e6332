// File I/O of the DCT workload (library dtflop_dct_io, built with DTFLOP_IMAGE_IO): images
// through OpenCV's codecs, CSV of fields and dots, and colour-mapped PNG overlays of a field
// on the image with a colour bar and units.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "workloads/dct/kernels.hpp"
#include "workloads/dct/specimen.hpp"
#include "workloads/dct/uncertainty.hpp"

namespace dtflop::dct {

// Images dtflop reads: at most kMaxImageSide px a side and kMaxImagePixels in all (the DCT
// workload's frames go up to 24 MP), files of at most kMaxImageFileBytes.
inline constexpr std::int64_t kMaxImageSide = 16384;
inline constexpr std::int64_t kMaxImagePixels = 64'000'000;
inline constexpr std::uintmax_t kMaxImageFileBytes = std::uintmax_t{1} << 30;

// One-channel 8- or 16-bit image (colour is converted to grey). Throws InputError with the
// path when the file is missing, unreadable, too large (checked before decoding where the
// format's header says) or of an unsupported depth.
cv::Mat read_grey(const std::filesystem::path& path);
// Decodes an image held in memory as read_grey() does a file; `name` names it in messages.
cv::Mat decode_grey(const std::string& bytes, const std::filesystem::path& name);
// PNG or TIFF by extension, written atomically (write_file_atomically); throws InputError when
// writing fails.
void write_image(const std::filesystem::path& path, const cv::Mat& image);

// One row per point; positions and displacements in px, strains in microstrain, as the header says;
// sd_* is each value's standard deviation (uncertainty.hpp), empty where unknown.
inline constexpr const char* kCsvHeader =
    "x_px,y_px,u_x_px,u_y_px,e_xx_microstrain,e_yy_microstrain,e_xy_microstrain,valid,status,support,"
    "sd_u_x_px,sd_u_y_px,sd_e_xx_microstrain,sd_e_yy_microstrain,sd_e_xy_microstrain";
void write_fields_csv(const std::filesystem::path& path, const std::vector<Vec2>& points,
                      const std::vector<FieldValue<double>>& fields, const std::vector<FieldSigma>& sigma = {});

// The dots of one frame, one row per reference dot (matched or lost, with why) and one per dot
// of the frame no reference dot matched (appeared): reference and deformed centroid, labelled
// area, displacement, the deformed dot's mean grey level (over its box's pixels on the dot side
// of the threshold; empty with an adaptive threshold) and the centroids' standard deviations.
inline constexpr const char* kDotsCsvHeader =
    "ref_id,frame_id,status,reason,x_ref_px,y_ref_px,area_ref_px,x_px,y_px,area_px,u_x_px,u_y_px,"
    "mean_intensity,sd_ref_px,sd_px";
void write_dots_csv(const std::filesystem::path& path, const std::vector<DotObservation>& reference,
                    const std::vector<DotObservation>& frame, const Matches& matches, const cv::Mat& frame_image,
                    double threshold, Polarity polarity, const FrameUncertainty* uncertainty = nullptr);

enum class Field { ux, uy, exx, eyy, exy };
std::string field_name(Field f);   // "u_x", ... "e_xy"
std::string field_unit(Field f);   // "px" or "microstrain"
double field_value(const FieldValue<double>& v, Field f);  // strain in microstrain

// The limits a colour bar spans.
struct ColourRange {
  double lo = -1, hi = 1;
  bool from_data = false;  // false: no finite value to take them from
};
// The finite values' range, symmetric about zero when they change sign, widened when flat.
ColourRange colour_range(const std::vector<double>& values);
// "LO:HI" (finite, LO < HI); `option` names the flag in the message.
ColourRange parse_colour_range(const std::string& text, const std::string& option);
// Round tick values (1, 2, 2.5 or 5 x 10^k apart) within [lo, hi], at most about `most`.
std::vector<double> nice_ticks(double lo, double hi, int most);

// Colour map of `values` (one per point of an nx x ny grid, NaN = invalid) drawn over the
// grey `image` across the grid's extent, with a colour bar titled `title` [`unit`] and ticks at
// round values. The colours span `range` (values beyond it take the end colours), else
// colour_range(values): a diverging map (blue - grey - red, perceptually even) when the range
// spans zero, viridis otherwise. Pixels not surrounded by valid points stay the image. Returns
// a BGR image.
cv::Mat overlay(const cv::Mat& image, const std::vector<Vec2>& points, int nx, int ny,
                const std::vector<double>& values, const std::string& title, const std::string& unit,
                std::optional<ColourRange> range = std::nullopt);

}  // namespace dtflop::dct
