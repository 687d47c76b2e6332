// Frame sources on peers the tests make: a video file (VideoWriter), an image sequence, a
// GStreamer videotestsrc pipeline; pixel formats; source names; bad input.
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "model/errors.hpp"
#include "sources/frame_source.hpp"
#include "sources/pixels.hpp"
#include "tests/support/temp_dir.hpp"

namespace dtflop::sources {
namespace {

namespace fs = std::filesystem;

// A frame whose mean grey level encodes k (20 + 8k), with a few dark dots.
cv::Mat numbered_frame(int k, cv::Size size) {
  cv::Mat m(size, CV_8UC3, cv::Scalar::all(20 + 8 * k));
  return m;
}

fs::path write_video(const fs::path& dir, int frames, double fps, cv::Size size) {
  const fs::path p = dir / "clip.avi";
  cv::VideoWriter w(p.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size);
  if (!w.isOpened()) return {};
  for (int k = 0; k < frames; ++k) w.write(numbered_frame(k, size));
  return p;
}

TEST(PixelFormats, Mono8And16KeepTheirValues) {
  const std::uint8_t m8[6] = {0, 1, 2, 127, 128, 255};
  const cv::Mat a = to_grey(m8, 6, 3, 2, pixel_layout("Mono8"));
  ASSERT_EQ(a.type(), CV_8UC1);
  EXPECT_EQ(a.at<std::uint8_t>(1, 2), 255);
  EXPECT_EQ(a.at<std::uint8_t>(1, 0), 127);
  const std::uint8_t m16[4] = {0x34, 0x12, 0xff, 0xff};  // little endian 0x1234, 0xffff
  const cv::Mat b = to_grey(m16, 4, 2, 1, pixel_layout("Mono16"));
  ASSERT_EQ(b.type(), CV_16UC1);
  EXPECT_EQ(b.at<std::uint16_t>(0, 0), 0x1234);
  EXPECT_EQ(b.at<std::uint16_t>(0, 1), 0xffff);
}

TEST(PixelFormats, TwelveBitsFillTheTopOfSixteen) {
  const std::uint8_t m12[4] = {0xff, 0x0f, 0x01, 0x00};  // 4095, 1
  const PixelLayout l = pixel_layout("Mono12");
  EXPECT_EQ(l.bits, 12);
  const cv::Mat g = to_grey(m12, 4, 2, 1, l);
  ASSERT_EQ(g.type(), CV_16UC1);
  EXPECT_EQ(g.at<std::uint16_t>(0, 0), 4095 << 4);
  EXPECT_EQ(g.at<std::uint16_t>(0, 1), 1 << 4);
  // Every 12-bit value stays distinct: no depth is lost.
  std::vector<std::uint8_t> all(2 * 4096);
  for (int v = 0; v < 4096; ++v) {
    all[2 * v] = static_cast<std::uint8_t>(v & 0xff);
    all[2 * v + 1] = static_cast<std::uint8_t>(v >> 8);
  }
  const cv::Mat r = to_grey(all.data(), all.size(), 64, 64, l);
  for (int v = 0; v < 4096; ++v) ASSERT_EQ(r.at<std::uint16_t>(v / 64, v % 64) >> 4, v);
}

TEST(PixelFormats, PackedTwelveBits) {
  // p0 = 0xABC, p1 = 0x123.
  const std::uint8_t gev[3] = {0xAB, 0x3C, 0x12};  // Mono12Packed: p0[11:4], p1[3:0]<<4|p0[3:0], p1[11:4]
  const cv::Mat a = to_grey(gev, 3, 2, 1, pixel_layout("Mono12Packed"));
  EXPECT_EQ(a.at<std::uint16_t>(0, 0) >> 4, 0xABC);
  EXPECT_EQ(a.at<std::uint16_t>(0, 1) >> 4, 0x123);
  const std::uint8_t pfnc[3] = {0xBC, 0x3A, 0x12};  // Mono12p: p0[7:0], p1[3:0]<<4|p0[11:8], p1[11:4]
  const cv::Mat b = to_grey(pfnc, 3, 2, 1, pixel_layout("Mono12p"));
  EXPECT_EQ(b.at<std::uint16_t>(0, 0) >> 4, 0xABC);
  EXPECT_EQ(b.at<std::uint16_t>(0, 1) >> 4, 0x123);
}

TEST(PixelFormats, BayerOfAGreyScenePreservesItsLevelAndDepth) {
  // A grey scene seen through any colour filter gives the same value at every site.
  std::vector<std::uint8_t> raw8(16 * 16, 90);
  const cv::Mat g8 = to_grey(raw8.data(), raw8.size(), 16, 16, pixel_layout("BayerRG8"));
  ASSERT_EQ(g8.type(), CV_8UC1);
  EXPECT_NEAR(g8.at<std::uint8_t>(8, 8), 90, 1);
  std::vector<std::uint8_t> raw12(2 * 16 * 16);
  for (std::size_t i = 0; i < raw12.size(); i += 2) {
    raw12[i] = 0x01;  // 0x801 = 2049: an odd value that 8 bits could not hold
    raw12[i + 1] = 0x08;
  }
  const cv::Mat g12 = to_grey(raw12.data(), raw12.size(), 16, 16, pixel_layout("BayerGB12"));
  ASSERT_EQ(g12.type(), CV_16UC1);
  EXPECT_NEAR(g12.at<std::uint16_t>(8, 8), 2049 << 4, 16);
}

TEST(PixelFormats, WrongSizeOrFormatIsRefused) {
  std::vector<std::uint8_t> b(10);
  EXPECT_THROW(to_grey(b.data(), b.size(), 4, 4, pixel_layout("Mono8")), InputError);
  EXPECT_THROW(to_grey(b.data(), b.size(), 5, 1, pixel_layout("RGB8")), InputError);
  EXPECT_EQ(pixel_layout("YUV422").format, PixelFormat::unsupported);
}

TEST(SourceSpecs, FormsAndOptions) {
  auto s = parse_source_spec("aravis:Aravis-Fake-GV01?exposure=1000&gain=2&fps=30&roi=0,0,256,128&format=Mono16");
  EXPECT_EQ(s.kind, SourceSpec::Kind::aravis);
  EXPECT_EQ(s.target, "Aravis-Fake-GV01");
  EXPECT_DOUBLE_EQ(*s.exposure_us, 1000);
  EXPECT_DOUBLE_EQ(*s.gain_db, 2);
  EXPECT_DOUBLE_EQ(*s.fps, 30);
  EXPECT_EQ(*s.roi, cv::Rect(0, 0, 256, 128));
  EXPECT_EQ(s.pixel_format, "Mono16");
  EXPECT_EQ(parse_source_spec("gst:videotestsrc ! video/x-raw,format=GRAY8 ! appsink name=a?b").target,
            "videotestsrc ! video/x-raw,format=GRAY8 ! appsink name=a?b");
  EXPECT_EQ(parse_source_spec("def_%04d.png").kind, SourceSpec::Kind::images);
  EXPECT_EQ(parse_source_spec("clip.mp4").kind, SourceSpec::Kind::file);
  EXPECT_EQ(parse_source_spec("device:2").target, "2");
  EXPECT_TRUE(parse_source_spec("file:a.avi?paced=1&fps=30&buffer=2").paced);
  for (const char* bad : {"", "device:x", "device:-1", "file:", "aravis:X?gain=nan", "aravis:X?roi=0,0,0,5",
                          "aravis:X?colour=1", "aravis:X?exposure", "file:a.avi?fps=1e999"})
    EXPECT_THROW(parse_source_spec(bad), InputError) << bad;
}

TEST(VideoFile, EveryFrameInOrderWithTimestampsAndNoDrops) {
  const auto dir = test::fresh_test_dir("dtflop_src");
  const fs::path clip = write_video(dir, 20, 30, {320, 240});
  if (clip.empty()) GTEST_SKIP() << "OpenCV cannot write MJPG AVI here (no FFmpeg/videoio writer)";
  auto src = open_source(parse_source_spec("file:" + clip.string()));
  Frame f;
  int n = 0;
  while (src->next(f)) {
    ASSERT_EQ(f.image.type(), CV_8UC1);
    ASSERT_EQ(f.image.size(), cv::Size(320, 240));
    EXPECT_EQ(f.sequence, static_cast<std::uint64_t>(n));
    EXPECT_NEAR(f.timestamp_s, n / 30.0, 1e-3);
    EXPECT_NEAR(cv::mean(f.image)[0], 20 + 8 * n, 3);  // the frame written as k-th
    ++n;
  }
  EXPECT_EQ(n, 20);
  EXPECT_EQ(src->stats().delivered, 20u);
  EXPECT_EQ(src->stats().dropped, 0u);
  EXPECT_FALSE(src->stats().disconnected);
}

TEST(VideoFile, PacedLikeACameraASlowReaderLosesFramesAndTheyAreCounted) {
  const auto dir = test::fresh_test_dir("dtflop_src");
  const fs::path clip = write_video(dir, 30, 60, {160, 120});
  if (clip.empty()) GTEST_SKIP() << "OpenCV cannot write MJPG AVI here";
  auto src = open_source(parse_source_spec("file:" + clip.string() + "?paced=1&buffer=2"));
  Frame f;
  std::uint64_t last = 0;
  while (src->next(f)) {
    last = f.sequence;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // three frame periods
  }
  EXPECT_EQ(last, 29u);  // the newest frame always reaches the reader
  EXPECT_GT(src->stats().dropped, 0u);
  EXPECT_EQ(src->stats().delivered + src->stats().dropped, 30u);  // every frame delivered or counted lost
}

TEST(ImageSequence, SixteenBitFramesKeepTheirValues) {
  const auto dir = test::fresh_test_dir("dtflop_src");
  for (int k = 0; k < 4; ++k) {
    cv::Mat m(48, 64, CV_16UC1, cv::Scalar(1000 + 257 * k));
    m.at<std::uint16_t>(3, 5) = static_cast<std::uint16_t>(65535 - k);
    ASSERT_TRUE(cv::imwrite((dir / fmt::format("f_{:03d}.png", k)).string(), m));
  }
  auto src = open_source(parse_source_spec("images:" + (dir / "f_%03d.png").string()));
  Frame f;
  int n = 0;
  while (src->next(f)) {
    ASSERT_EQ(f.image.type(), CV_16UC1);
    EXPECT_EQ(f.bits, 16);
    EXPECT_EQ(f.sequence, static_cast<std::uint64_t>(n));
    EXPECT_EQ(f.image.at<std::uint16_t>(0, 0), 1000 + 257 * n);
    EXPECT_EQ(f.image.at<std::uint16_t>(3, 5), 65535 - n);
    ++n;
  }
  EXPECT_EQ(n, 4);
}

TEST(ImageSequence, AFrameOfAnotherSizeStopsTheStreamSayingSo) {
  const auto dir = test::fresh_test_dir("dtflop_src");
  for (int k = 0; k < 3; ++k)
    ASSERT_TRUE(cv::imwrite((dir / fmt::format("g_{}.png", k)).string(),
                            cv::Mat(k == 2 ? 50 : 40, 60, CV_8UC1, cv::Scalar(100))));
  auto src = open_source(parse_source_spec((dir / "g_%d.png").string()));
  Frame f;
  ASSERT_TRUE(src->next(f));
  ASSERT_TRUE(src->next(f));
  try {
    src->next(f);
    FAIL() << "a 60x50 frame after 60x40 ones was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("60x50"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("share one size"), std::string::npos) << e.what();
  }
  EXPECT_EQ(src->stats().delivered, 2u);  // what came before is kept
}

bool have_gst_element(const char* name) {
  return std::system(fmt::format("gst-inspect-1.0 {} >/dev/null 2>&1", name).c_str()) == 0;
}

TEST(GStreamer, VideotestsrcPipelineStreamsItsFrames) {
  if (!have_gst_element("videotestsrc") || !have_gst_element("appsink"))
    GTEST_SKIP() << "gst-inspect-1.0, videotestsrc or appsink missing: install gstreamer1.0-tools and "
                    "gstreamer1.0-plugins-base (scripts/setup.sh --sanitize does)";
  auto src = open_source(parse_source_spec(
      "gst:videotestsrc num-buffers=12 pattern=checkers-8 ! video/x-raw,width=160,height=120,framerate=30/1 ! "
      "videoconvert ! video/x-raw,format=GRAY8 ! appsink"));
  Frame f;
  int n = 0;
  double last_t = -1;
  while (src->next(f)) {
    ASSERT_EQ(f.image.size(), cv::Size(160, 120));
    ASSERT_EQ(f.image.type(), CV_8UC1);
    EXPECT_GT(f.timestamp_s, last_t);
    last_t = f.timestamp_s;
    // checkers-8: squares of 8 px in two levels.
    const auto at = [&](int y, int x) { return static_cast<int>(f.image.at<std::uint8_t>(y, x)); };
    EXPECT_GT(std::abs(at(0, 0) - at(0, 8)), 30);
    EXPECT_EQ(at(0, 0), at(8, 8));
    EXPECT_EQ(at(0, 8), at(8, 0));
    EXPECT_EQ(at(0, 0), at(7, 7));
    ++n;
  }
  EXPECT_EQ(n, 12);
  EXPECT_EQ(src->stats().dropped, 0u);
}

TEST(GStreamer, APipelineThatDoesNotParseIsRefusedInOneLine) {
  try {
    open_source(parse_source_spec("gst:nosuchelement_dtflop ! appsink"));
    FAIL() << "accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("does not parse"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

TEST(BadSources, MissingFileDeviceAndPattern) {
  const auto dir = test::fresh_test_dir("dtflop_src");
  EXPECT_THROW(open_source(parse_source_spec("file:" + (dir / "none.mp4").string())), InputError);
  EXPECT_THROW(open_source(parse_source_spec("images:" + (dir / "none_%03d.png").string())), InputError);
  EXPECT_THROW(open_source(parse_source_spec("device:250")), InputError);
  // A file that is not a video.
  {
    std::FILE* fp = std::fopen((dir / "text.mp4").c_str(), "w");
    std::fputs("not a video\n", fp);
    std::fclose(fp);
  }
  EXPECT_THROW(open_source(parse_source_spec("file:" + (dir / "text.mp4").string())), InputError);
}

}  // namespace
}  // namespace dtflop::sources
