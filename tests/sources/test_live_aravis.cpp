// `dtflop live dct` end to end on a GigE Vision stream: fake_dot_camera (Aravis's fake camera
// serving dot images of known uniform tension, drawn by the independent renderer) started here
// on 127.0.0.1 and opened by its id, as test_aravis_source opens arv-fake-gv-camera-0.8. Each
// measured frame's fields are checked against the tension of the state the camera says it sent
// with that frame id, relative to the reference frame's state; the frames delivered and dropped
// are checked against the ids the camera sent.
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "sources/frame_source.hpp"
#include "tests/cli/run_cli.hpp"
#include "tests/support/temp_dir.hpp"

namespace dtflop::sources {
namespace {

namespace fs = std::filesystem;

// What the camera serves (fake_dot_camera's keys): a 704 x 544 rendering, of which the test's
// ROI (32, 32, 640, 480) is streamed; states of uniform tension e_xx = s, e_yy = -nu s about the
// rendering's centre, 3 frames each.
constexpr int kW = 704, kH = 544, kRoiX = 32, kRoiY = 32, kRoiW = 640, kRoiH = 480;
constexpr double kNu = 0.3;
const std::vector<double> kStrains = {0, 1e-3, 2.5e-3};
constexpr int kHold = 3;

// The helper as a child process; killed (SIGTERM, then SIGKILL) when the test ends, and by the
// kernel should the test itself die.
class DotCamera {
 public:
  DotCamera(const std::string& serial, const fs::path& dir) : log_(dir / "camera_log.csv"), out_(dir / "camera.out") {
    const std::string strains = fmt::format("{}", fmt::join(kStrains, ","));
    const std::vector<std::string> args = {FAKE_DOT_CAMERA,
                                           serial,
                                           log_.string(),
                                           "interface=127.0.0.1",
                                           fmt::format("width={}", kW),
                                           fmt::format("height={}", kH),
                                           "dots=200",
                                           "radius=6",
                                           "gap=8",
                                           fmt::format("nu={}", kNu),
                                           "strains=" + strains,
                                           fmt::format("hold={}", kHold)};
    pid_ = ::fork();
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      const int fd = ::open(out_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
      }
      std::vector<char*> argv;
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }
  ~DotCamera() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      for (int i = 0; i < 50 && ::waitpid(pid_, nullptr, WNOHANG) == 0; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  // Waits for "ready" (the images are rendered first); empty, or why it is not up.
  std::string wait_ready() {
    for (int i = 0; i < 1200; ++i) {
      if (test::slurp(out_).rfind("ready", 0) == 0) return {};
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return "fake_dot_camera exited: " + test::slurp(out_);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    return "fake_dot_camera did not come up in 120 s: " + test::slurp(out_);
  }
  // frame id -> state, from the camera's log.
  std::map<std::uint64_t, int> states() const {
    std::map<std::uint64_t, int> m;
    std::ifstream in(log_);
    for (std::string line; std::getline(in, line);) {
      std::uint64_t id = 0;
      int state = 0;
      char comma = 0;
      std::istringstream s(line);
      if (s >> id >> comma >> state) m[id] = state;
    }
    return m;
  }

 private:
  fs::path log_, out_;
  pid_t pid_ = -1;
};

std::vector<std::vector<std::string>> read_csv(const fs::path& p) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(p);
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string c; std::getline(s, c, ',');) cells.push_back(c);
    if (!line.empty() && line.back() == ',') cells.emplace_back();
    rows.push_back(cells);
  }
  return rows;
}

std::size_t column(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return i;
  ADD_FAILURE() << "no column " << name;
  return 0;
}

TEST(AravisLive, MeasuresTheRenderedTensionOfEachFrameTheFakeCameraSends) {
  if (!have_aravis()) GTEST_SKIP() << "dtflop was built without Aravis (install libaravis-dev)";
  const auto dir = test::fresh_test_dir("dtflop_live_aravis");
  const std::string serial = fmt::format("D{}", ::getpid() % 100000);
  DotCamera cam(serial, dir);
  const std::string why = cam.wait_ready();
  if (why.find("does not listen") != std::string::npos)
    GTEST_SKIP() << "no fake GigE Vision camera on 127.0.0.1 (" << why << "): a loopback interface and the free "
                 << "GVCP port 3956 are needed";
  ASSERT_TRUE(why.empty()) << why;
  {
    std::ofstream y(dir / "run.yaml");
    y << "backend: cpu-par\nthreads: 1\nsupport: 60dots\npoints: 8x8\n";
  }
  constexpr int kFrames = 10;
  const std::string source = fmt::format("aravis:Aravis-Fake-{}?format=Mono16&roi={},{},{},{}&fps=20&timeout=2",
                                         serial, kRoiX, kRoiY, kRoiW, kRoiH);
  const auto out = dir / "out";
  // A camera that has just come up may miss the first discovery; the source tries twice, and
  // this test once more.
  auto r = test::run_dtflop(fmt::format("live dct --config {} --source '{}' -o {} --max-frames {}",
                                        (dir / "run.yaml").string(), source, out.string(), kFrames));
  if (r.status == 2 && r.err.find("no camera") != std::string::npos)
    r = test::run_dtflop(fmt::format("live dct --config {} --source '{}' -o {} --max-frames {}",
                                     (dir / "run.yaml").string(), source, out.string(), kFrames));
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find(fmt::format("{} frames measured", kFrames)), std::string::npos) << r.out;

  std::ifstream sin(out / "summary.json");
  const auto js = nlohmann::json::parse(sin);
  ASSERT_TRUE(js.contains("reference_sequence")) << js.dump();
  const auto ref_seq = js["reference_sequence"].get<std::uint64_t>();
  const auto states = cam.states();
  ASSERT_TRUE(states.count(ref_seq)) << "the reference's id " << ref_seq << " is not one the camera sent";
  const double s_ref = kStrains[static_cast<std::size_t>(states.at(ref_seq))];

  const auto frames = read_csv(out / "frames.csv");
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kFrames + 1));  // header + one row per measured frame
  const std::size_t c_seq = column(frames[0], "sequence"), c_exx = column(frames[0], "mean_e_xx_microstrain"),
                    c_eyy = column(frames[0], "mean_e_yy_microstrain");
  // Frames: every measured id one the camera sent, ids rising; those between the reference and the
  // last measured one that were not delivered are exactly the frames counted dropped.
  std::uint64_t last = ref_seq;
  std::set<int> seen_states;
  for (std::size_t k = 1; k < frames.size(); ++k) {
    const auto& row = frames[k];
    const std::uint64_t seq = std::stoull(row[c_seq]);
    ASSERT_GT(seq, last) << "frame " << k;
    last = seq;
    ASSERT_TRUE(states.count(seq)) << "frame " << k << ": id " << seq << " is not one the camera sent";
    const int state = states.at(seq);
    ASSERT_GE(state, 0) << "the camera drew no dots into frame " << seq;
    seen_states.insert(state);
    // The truth: the state's tension relative to the reference's, as a small strain of the
    // reference image (positions x = c + (1 + s)(X - c) in both).
    const double s = kStrains[static_cast<std::size_t>(state)];
    const double ex = (s - s_ref) / (1 + s_ref), ey = (-kNu * s + kNu * s_ref) / (1 - kNu * s_ref);
    const double cx = 0.5 * (kW - 1) - kRoiX, cy = 0.5 * (kH - 1) - kRoiY;  // the centre in the ROI's pixels
    // Tolerances (16-bit noiseless renders, 166 dots of 6 px radius in view, 60-dot supports):
    // mean strains within 10 microstrain (measured within 5), every point's displacement within
    // 0.01 px (measured 0.002), its strains within 30 microstrain RMS over the frame (measured 18
    // at 2500) and 120 at worst (measured 61, at the grid's corners, where supports are one-sided).
    EXPECT_NEAR(std::stod(row[c_exx]), 1e6 * ex, 10) << "frame " << k << " (id " << seq << ", state " << state << ")";
    EXPECT_NEAR(std::stod(row[c_eyy]), 1e6 * ey, 10) << "frame " << k;
    const auto fields = read_csv(out / fmt::format("frame_{:06d}.csv", k));
    ASSERT_EQ(fields.size(), 65u) << k;  // 8 x 8 points
    const auto& h = fields[0];
    const std::size_t x = column(h, "x_px"), y = column(h, "y_px"), ux = column(h, "u_x_px"), uy = column(h, "u_y_px"),
                      exx = column(h, "e_xx_microstrain"), eyy = column(h, "e_yy_microstrain"),
                      exy = column(h, "e_xy_microstrain"), valid = column(h, "valid");
    int ok = 0;
    double worst_u = 0, worst_e = 0, sum_e2 = 0;
    for (std::size_t i = 1; i < fields.size(); ++i) {
      const auto& f = fields[i];
      if (f[valid] != "1") continue;
      ++ok;
      const double px = std::stod(f[x]), py = std::stod(f[y]);
      worst_u = std::max({worst_u, std::abs(std::stod(f[ux]) - ex * (px - cx)),
                          std::abs(std::stod(f[uy]) - ey * (py - cy))});
      const double dxx = std::stod(f[exx]) - 1e6 * ex, dyy = std::stod(f[eyy]) - 1e6 * ey, dxy = std::stod(f[exy]);
      worst_e = std::max({worst_e, std::abs(dxx), std::abs(dyy), std::abs(dxy)});
      sum_e2 += dxx * dxx + dyy * dyy + dxy * dxy;
    }
    EXPECT_EQ(ok, 64) << "frame " << k;
    EXPECT_LE(worst_u, 0.01) << "frame " << k << " (state " << state << "): worst displacement error, px";
    EXPECT_LE(worst_e, 120) << "frame " << k << " (state " << state << "): worst strain error, microstrain";
    EXPECT_LE(std::sqrt(sum_e2 / (3.0 * std::max(ok, 1))), 30) << "frame " << k << ": strain RMS error, microstrain";
  }
  // 1 + 10 frames delivered span at least 11 ids: past the 2 x 3 frames of states 0 and 1.
  EXPECT_TRUE(seen_states.count(static_cast<int>(kStrains.size()) - 1)) << "the last state was never measured";
  EXPECT_EQ(js["frames_measured"].get<int>(), kFrames);
  EXPECT_EQ(js["frames_delivered"].get<std::uint64_t>(), static_cast<std::uint64_t>(kFrames + 1));
  EXPECT_EQ(js["frames_delivered"].get<std::uint64_t>() + js["frames_dropped"].get<std::uint64_t>(),
            last - ref_seq + 1)
      << "delivered and dropped frames do not account for the ids " << ref_seq << ".." << last;
  // The camera sent every id in that span (so a drop is the receiver's, counted above).
  for (std::uint64_t id = ref_seq; id <= last; ++id) EXPECT_TRUE(states.count(id)) << id;
}

}  // namespace
}  // namespace dtflop::sources
