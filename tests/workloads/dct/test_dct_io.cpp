// Image and CSV I/O of the DCT workload: round trips keep depth and values, bad files give
// InputError naming them, the CSV marks invalid points, overlays carry a colour bar.
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
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

// A header declaring a huge image is refused before OpenCV allocates it (a 20-byte PPM declaring
// 8577x85777 made it allocate 2.2 GB; found by fuzz_image), in every format that is decoded.
TEST(DctIo, HugeDeclaredSizesAreRefusedBeforeDecoding) {
  auto encoded = [](const char* ext) {
    std::vector<std::uint8_t> buf;
    EXPECT_TRUE(cv::imencode(ext, cv::Mat(6, 9, CV_8U, cv::Scalar(50)), buf)) << ext;
    return std::string(buf.begin(), buf.end());
  };
  auto put16 = [](std::string& b, std::size_t at, unsigned v, bool big) {
    b[at + (big ? 1 : 0)] = static_cast<char>(v & 0xff);
    b[at + (big ? 0 : 1)] = static_cast<char>(v >> 8);
  };
  std::vector<std::pair<std::string, std::string>> cases;  // name, bytes
  cases.emplace_back("ppm", "P6\n8577\n85777\n255\n\x1a\x0a\x74\xdc");
  cases.emplace_back("pgm", "P5 # comment\n40000 40000 255\n");
  cases.emplace_back("ppm-junk", "P6\n8554&\n85777\x1a\n7\nt");  // a header OpenCV read as 8554x85777
  std::string bmp = encoded(".bmp");  // BITMAPINFOHEADER: 32-bit width and height at bytes 18 and 22
  put16(bmp, 18, 40000, false);
  put16(bmp, 22, 40000, false);
  cases.emplace_back("bmp", bmp);
  std::string jpg = encoded(".jpg");  // SOF0: height and width after length and precision
  const std::size_t sof = jpg.find("\xff\xc0");
  ASSERT_NE(sof, std::string::npos);
  put16(jpg, sof + 5, 40000, true);
  put16(jpg, sof + 7, 40000, true);
  cases.emplace_back("jpg", jpg);
  // TIFF, little-endian: first IFD at 8 holding ImageWidth and ImageLength as SHORTs.
  std::string tif("II*\0\x08\0\0\0\x02\0", 10);
  for (unsigned tag : {256u, 257u}) {
    std::string e(12, '\0');
    put16(e, 0, tag, false);
    put16(e, 2, 3, false);
    e[4] = 1;
    put16(e, 8, 40000, false);
    tif += e;
  }
  tif += std::string(4, '\0');
  cases.emplace_back("tif", tif);
  for (const auto& [name, bytes] : cases) {
    try {
      (void)decode_grey(bytes, "big." + name);
      ADD_FAILURE() << name << " was decoded";
    } catch (const InputError& e) {
      const std::string m = e.what();
      EXPECT_TRUE(m.find("40000x40000 px") != std::string::npos || m.find("8577x85777 px") != std::string::npos ||
                  m.find("'big.ppm-junk' is damaged: its header") != std::string::npos)
          << name << ": " << m;
    }
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
  EXPECT_EQ(header,
            "x_px,y_px,u_x_px,u_y_px,e_xx_microstrain,e_yy_microstrain,e_xy_microstrain,valid,status,support,"
            "sd_u_x_px,sd_u_y_px,sd_e_xx_microstrain,sd_e_yy_microstrain,sd_e_xy_microstrain");
  EXPECT_EQ(l1, "1.000,2.000,0.500000,-0.250000,1000,-300,20,1,ok,60,,,,,");  // strains in microstrain, as on screen
  EXPECT_EQ(l2, "3.000,4.000,,,,,,0,too_few_dots,4,,,,,");
  // With deviations: px and microstrain like the values.
  std::vector<FieldSigma> sd(2);
  sd[0] = {0.001, 0.002, 3e-6, 4e-6, 5e-6};
  write_fields_csv(tmp("s.csv"), pts, f, sd);
  std::ifstream in2(tmp("s.csv"));
  std::getline(in2, header);
  std::getline(in2, l1);
  std::getline(in2, l2);
  EXPECT_EQ(l1, "1.000,2.000,0.500000,-0.250000,1000,-300,20,1,ok,60,0.001,0.002,3,4,5");
  EXPECT_EQ(l2, "3.000,4.000,,,,,,0,too_few_dots,4,,,,,");
  EXPECT_THROW(write_fields_csv(tmp("g.csv"), pts, {}), InputError);
}

TEST(DctIo, DotsCsvSaysWhatWasMatchedLostAndAppeared) {
  std::vector<DotObservation> ref(2), def(2);
  ref[0].x = 10; ref[0].y = 20; ref[0].area = 50;
  ref[1].x = 40; ref[1].y = 20; ref[1].area = 52;
  def[0].x = 10.5; def[0].y = 19.75; def[0].area = 49; def[0].box = cv::Rect(6, 16, 9, 9);
  def[1].x = 80; def[1].y = 30; def[1].area = 40; def[1].box = cv::Rect(76, 26, 9, 9);
  Matches m;
  m.ref_to_def = {0, -1};
  m.lost_reason = {LostReason::none, LostReason::ambiguous};
  m.appeared = {1};
  cv::Mat img(60, 100, CV_8U, cv::Scalar(200));
  img(cv::Rect(8, 18, 5, 5)).setTo(40);
  write_dots_csv(tmp("d.csv"), ref, def, m, img, 120, Polarity::dark_dots);
  std::ifstream in(tmp("d.csv"));
  std::string header, a, b, c;
  std::getline(in, header);
  std::getline(in, a);
  std::getline(in, b);
  std::getline(in, c);
  EXPECT_EQ(header, kDotsCsvHeader);
  EXPECT_EQ(a, "0,0,matched,,10.0000,20.0000,50,10.5000,19.7500,49,0.50000,-0.25000,40.00,,");
  EXPECT_EQ(b, "1,,lost,ambiguous,40.0000,20.0000,52,,,,,,,,");
  EXPECT_EQ(c, ",1,appeared,unclaimed,,,,80.0000,30.0000,40,,,,,");
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

TEST(DctIo, TicksAreRoundAndRangesSymmetricWhenSigned) {
  EXPECT_EQ(nice_ticks(-487, 487, 7), (std::vector<double>{-400, -200, 0, 200, 400}));
  EXPECT_EQ(nice_ticks(350, 3120, 7), (std::vector<double>{500, 1000, 1500, 2000, 2500, 3000}));
  EXPECT_EQ(nice_ticks(0, 1, 6), (std::vector<double>{0, 0.2, 0.4, 0.6, 0.8, 1}));
  const ColourRange signed_range = colour_range({-30, 100, std::nan("")});
  EXPECT_DOUBLE_EQ(signed_range.lo, -100);
  EXPECT_DOUBLE_EQ(signed_range.hi, 100);
  const ColourRange one_signed = colour_range({1000, 1001});
  EXPECT_DOUBLE_EQ(one_signed.lo, 1000);
  EXPECT_DOUBLE_EQ(one_signed.hi, 1001);
  EXPECT_FALSE(colour_range({std::nan("")}).from_data);
  EXPECT_DOUBLE_EQ(parse_colour_range("-500:250", "--r").lo, -500);
  for (const char* bad : {"5:-5", "1:1", "a:b", "5", "nan:1", "1:2x"})
    EXPECT_THROW(parse_colour_range(bad, "--r"), InputError) << bad;
}

TEST(DctIo, AFixedRangeColoursAlikeAndZeroIsTheDivergingMapsGrey) {
  cv::Mat img(200, 300, CV_8U, cv::Scalar(128));
  std::vector<Vec2> pts;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 5; ++i) pts.push_back({20.0 + 60 * i, 20.0 + 50 * j});
  const std::vector<double> zero(pts.size(), 0.0), big(pts.size(), 5000.0), top(pts.size(), 100.0);
  const ColourRange r{-100, 100, true};
  // Zero in a signed range: the map's light grey middle (blended over grey: still grey).
  const cv::Vec3b z = overlay(img, pts, 5, 4, zero, "e_xx", "microstrain", r).at<cv::Vec3b>(60, 60);
  EXPECT_LE(std::abs(int(z[0]) - int(z[2])), 3);
  // Beyond the range takes the end colour: 5000 looks like 100.
  EXPECT_EQ(overlay(img, pts, 5, 4, big, "e_xx", "microstrain", r).at<cv::Vec3b>(60, 60),
            overlay(img, pts, 5, 4, top, "e_xx", "microstrain", r).at<cv::Vec3b>(60, 60));
  const cv::Vec3b red = overlay(img, pts, 5, 4, top, "e_xx", "microstrain", r).at<cv::Vec3b>(60, 60);
  EXPECT_GT(red[2], red[0] + 40);  // BGR: the warm end
}

}  // namespace
}  // namespace dtflop::dct
