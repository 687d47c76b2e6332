// The Aravis source against Aravis's fake GigE Vision camera (arv-fake-gv-camera-0.8, from
// aravis-tools), started here on 127.0.0.1, opened by its id, streamed, and killed mid-stream.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "model/errors.hpp"
#include "sources/frame_source.hpp"

namespace dtflop::sources {
namespace {

constexpr const char* kFake = "arv-fake-gv-camera-0.8";

bool on_path(const char* exe) {
  return std::system(fmt::format("command -v {} >/dev/null 2>&1", exe).c_str()) == 0;
}

// The fake camera as a child process, serial `serial`: its id is "Aravis-Fake-<serial>".
class FakeCamera {
 public:
  explicit FakeCamera(std::string serial) : serial_(std::move(serial)) { start(); }
  ~FakeCamera() { stop(); }
  void start() {
    pid_ = ::fork();
    if (pid_ == 0) {
      const int null = ::open("/dev/null", O_WRONLY);
      if (null >= 0) {
        ::dup2(null, 1);
        ::dup2(null, 2);
      }
      ::execlp(kFake, kFake, "-i", "127.0.0.1", "-s", serial_.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
  }
  void stop() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    pid_ = -1;
  }
  std::string id() const { return "Aravis-Fake-" + serial_; }

 private:
  std::string serial_;
  pid_t pid_ = -1;
};

std::string serial() { return fmt::format("T{}", ::getpid() % 100000); }

// Opens the camera, allowing it a few seconds to come up.
std::unique_ptr<FrameSource> open_when_up(const std::string& spec) {
  for (int i = 0;; ++i) {
    try {
      return open_source(parse_source_spec(spec));
    } catch (const InputError&) {
      if (i >= 4) throw;
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
    }
  }
}

class Aravis : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_aravis()) GTEST_SKIP() << "dtflop was built without Aravis (install libaravis-dev)";
    if (!on_path(kFake))
      GTEST_SKIP() << kFake << " is missing: install aravis-tools (scripts/setup.sh --sanitize does)";
  }
};

TEST_F(Aravis, StreamsMono16WithRoiAndStopsCleanlyWhenTheCameraIsKilled) {
  FakeCamera cam(serial());
  auto src = open_when_up(fmt::format("aravis:{}?format=Mono16&roi=0,0,256,128&fps=50&reopen=0&timeout=0.5",
                                      cam.id()));
  EXPECT_NE(src->describe().find("Mono16"), std::string::npos) << src->describe();
  Frame f;
  std::uint64_t first = 0, last = 0;
  double last_t = -1;
  for (int k = 0; k < 8; ++k) {
    ASSERT_TRUE(src->next(f)) << src->stats().last_error;
    ASSERT_EQ(f.image.type(), CV_16UC1);
    ASSERT_EQ(f.image.size(), cv::Size(256, 128));
    EXPECT_EQ(f.bits, 16);
    if (k == 0) first = f.sequence;
    else EXPECT_GT(f.sequence, last);
    EXPECT_GT(f.timestamp_s, last_t);
    last = f.sequence;
    last_t = f.timestamp_s;
  }
  // The fake camera's image is a moving pattern: not flat.
  double lo = 0, hi = 0;
  cv::minMaxLoc(f.image, &lo, &hi);
  EXPECT_LT(lo, hi);
  // Frames numbered first..last were all delivered or counted dropped.
  EXPECT_EQ(src->stats().delivered + src->stats().dropped, last - first + 1);
  cam.stop();  // mid-stream
  int after = 0;
  while (src->next(f)) ++after;  // what was already in flight
  EXPECT_TRUE(src->stats().disconnected);
  EXPECT_NE(src->stats().last_error.find("no frame"), std::string::npos) << src->stats().last_error;
  EXPECT_EQ(src->stats().delivered, static_cast<std::uint64_t>(8 + after));  // what came before is kept
}

TEST_F(Aravis, ReopensACameraThatComesBack) {
  FakeCamera cam(serial());
  auto src = open_when_up(fmt::format("aravis:{}?format=Mono8&fps=50&reopen=8&backoff=250&timeout=0.5", cam.id()));
  Frame f;
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(src->next(f)) << src->stats().last_error;
  EXPECT_EQ(f.image.type(), CV_8UC1);
  cam.stop();
  cam.start();  // back at once; the source notices the lost stream, then reopens it
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(src->next(f)) << src->stats().last_error;
  EXPECT_EQ(src->stats().reopened, 1);
  EXPECT_FALSE(src->stats().disconnected);
  EXPECT_GE(src->stats().delivered, 10u);
}

TEST_F(Aravis, ACameraThatIsNotThereIsRefusedInOneLine) {
  try {
    open_source(parse_source_spec("aravis:Aravis-Fake-NOSUCHCAM?reopen=0"));
    FAIL() << "opened a camera that is not there";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("no camera 'Aravis-Fake-NOSUCHCAM' found"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace dtflop::sources
