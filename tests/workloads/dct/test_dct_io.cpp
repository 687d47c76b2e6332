// Image and CSV I/O of the DCT workload: round trips keep depth and values, bad files give
// InputError naming them, the CSV marks invalid points, overlays carry a colour bar.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "model/errors.hpp"
#include "workloads/dct/io.hpp"

namespace dtflop::dct {
namespace {

std::filesystem::path tmp(const std::string& name) {
  const auto dir = std::filesystem::path(DTFLOP_BINARY_DIR) / "test-output" / "dct_io";
  std::filesystem::create_directories(dir);
  return dir / name;
}

TEST(DctIo, ImagesRoundTripInEightAndSixteenBits) {
  cv::Mat a(37, 53, CV_8U), b(37, 53, CV_16U);
  cv::randu(a, 0, 256);
  cv::randu(b, 0, 65536);
  for (const char* ext : {".png", ".tiff"}) {
    write_image(tmp(std::string("a") + ext), a);
    write_image(tmp(std::string("b") + ext), b);
    const cv::Mat ra = read_grey(tmp(std::string("a") + ext)), rb = read_grey(tmp(std::string("b") + ext));
    ASSERT_EQ(ra.type(), CV_8U);
    ASSERT_EQ(rb.type(), CV_16U);
    EXPECT_EQ(cv::norm(ra, a, cv::NORM_INF), 0) << ext;
    EXPECT_EQ(cv::norm(rb, b, cv::NORM_INF), 0) << ext;
  }
  // Colour images become grey.
  cv::Mat c(10, 10, CV_8UC3, cv::Scalar(10, 20, 30));
  write_image(tmp("c.png"), c);
  EXPECT_EQ(read_grey(tmp("c.png")).channels(), 1);
}

TEST(DctIo, BadFilesSayWhichAndWhy) {
  try {
    read_grey(tmp("missing.png"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.png"), std::string::npos);
  }
  std::ofstream(tmp("junk.png")) << "not an image";
  EXPECT_THROW(read_grey(tmp("junk.png")), InputError);
  EXPECT_THROW(write_image(tmp("x.unknownext"), cv::Mat(4, 4, CV_8U, cv::Scalar(0))), InputError);
}

TEST(DctIo, DecodesTheStillFormatsAndRefusesOthersBeforeOpenCv) {
  const cv::Mat a(6, 9, CV_8U, cv::Scalar(77));
  for (const char* ext : {".png", ".tiff", ".jpg", ".bmp", ".pgm"}) {
    std::vector<std::uint8_t> buf;
    ASSERT_TRUE(cv::imencode(ext, a, buf)) << ext;
    const cv::Mat r = decode_grey(std::string(buf.begin(), buf.end()), std::string("x") + ext);
    EXPECT_EQ(r.cols, 9) << ext;
    EXPECT_EQ(r.rows, 6) << ext;
  }
  // A DICOM preamble ("DICM" at byte 128) would reach GDCM through OpenCV, which aborts on damaged
  // files (found by fuzz_image; the input is in fuzz/corpus/image).
  std::string dicom(128, '\0');
  dicom += "DICM";
  dicom += std::string(64, '\x25');
  // The same behind a PGM magic number without the white space PGM needs after it.
  std::string pgm = dicom;
  pgm.replace(0, 3, "P5\x01");
  EXPECT_THROW((void)decode_grey(pgm, "scan.pgm"), InputError);
  try {
    (void)decode_grey(dicom, "scan.dcm");
    FAIL() << "a DICOM file was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'scan.dcm' is not a PNG, TIFF, JPEG, BMP or PGM/PPM"), std::string::npos)
        << e.what();
  }
}

TEST(DctIo, FieldsCsvMarksInvalidPoints) {
  std::vector<Vec2> pts{{1, 2}, {3, 4}};
  std::vector<FieldValue<double>> f(2);
  f[0] = {0.5, -0.25, 1e-3, -3e-4, 2e-5, PointStatus::ok, 60};
  f[1].status = PointStatus::too_few_dots;
  f[1].support = 4;
  write_fields_csv(tmp("f.csv"), pts, f);
  std::ifstream in(tmp("f.csv"));
  std::string header, l1, l2;
  std::getline(in, header);
  std::getline(in, l1);
  std::getline(in, l2);
  EXPECT_EQ(header, "x,y,u_x,u_y,e_xx,e_yy,e_xy,valid,status,support");
  EXPECT_EQ(l1, "1.000,2.000,0.500000,-0.250000,0.001,-0.0003,2e-05,1,ok,60");
  EXPECT_EQ(l2, "3.000,4.000,,,,,,0,too_few_dots,4");
  EXPECT_THROW(write_fields_csv(tmp("g.csv"), pts, {}), InputError);
}

TEST(DctIo, OverlayHasTheImageAndAColourBar) {
  cv::Mat img(200, 300, CV_16U, cv::Scalar(30000));
  std::vector<Vec2> pts;
  std::vector<double> v;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 5; ++i) {
      pts.push_back({20.0 + 60 * i, 20.0 + 50 * j});
      v.push_back(i == 2 && j == 2 ? std::nan("") : i - 2.0);
    }
  const cv::Mat o = overlay(img, pts, 5, 4, v, "e_xx", "microstrain");
  EXPECT_EQ(o.type(), CV_8UC3);
  EXPECT_EQ(o.rows, 200);
  EXPECT_GT(o.cols, 300);
  // Coloured where valid (not grey), grey where invalid.
  const cv::Vec3b a = o.at<cv::Vec3b>(25, 25);
  EXPECT_FALSE(a[0] == a[1] && a[1] == a[2]);
  const cv::Vec3b g = o.at<cv::Vec3b>(120, 140);
  EXPECT_TRUE(g[0] == g[1] && g[1] == g[2]);
  EXPECT_THROW(overlay(img, pts, 4, 4, v, "e", "u"), InputError);
}

}  // namespace
}  // namespace dtflop::dct
