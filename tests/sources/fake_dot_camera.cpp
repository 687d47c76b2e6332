// fake_dot_camera: Aravis's fake GigE Vision camera (libaravis' arv_gv_fake_camera_new, the
// camera arv-fake-gv-camera-0.8 runs) serving dot-pattern images of known deformation in place
// of its own ramp, for testing `dtflop live dct` end to end on a GigE Vision stream.
//
// The images are drawn by the independent renderer (tests/workloads/dct/independent_renderer:
// exact pixel coverage, no dtflop code): one per state, state k a uniform tension of strain
// STRAIN_k (e_yy = -nu e_xx) about the rendered image's centre ((W - 1) / 2, (H - 1) / 2), state
// 0 usually the undeformed pattern (strain 0). The camera serves state 0 for its first `hold`
// frames, state 1 for the next `hold`, ... and the last state from then on; the ROI the client
// sets is cut from the rendered image (offsets included, outside it the background). Each frame
// it fills is logged to LOG as "frame_id,state,strain", so a test knows every frame's truth by
// the camera's frame id.
//
//   fake_dot_camera SERIAL LOG [key=value ...]
//   keys: interface=127.0.0.1 width=640 height=480 dots=160 radius=6 gap=8 seed=7 noise=0 nu=0.3
//         strains=0,1e-3,2e-3 hold=3
//
// Pixel formats: Mono8 (the renderer's 8-bit images, with `noise` grey levels of Gaussian
// noise) and Mono16 (the noiseless coverage, 8-bit levels times 257). It prints "ready ID" on
// stdout once the camera listens (ID: Aravis-Fake-SERIAL) and runs until SIGTERM or SIGINT.
#include <signal.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "render.hpp"

extern "C" {
#include <arv.h>
}

namespace {

struct Served {
  std::vector<cv::Mat> mono8, mono16;  // per state, the rendered size
  std::vector<double> strains;
  long hold = 3;
  long filled = 0;
  double background = 200;
  FILE* log = nullptr;
  ArvFakeCamera* camera = nullptr;
};

template <typename T>
void cut(const cv::Mat& img, T fill, int x0, int y0, int w, int h, T* out) {
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int sx = x0 + x, sy = y0 + y;
      out[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)] =
          sx < img.cols && sy < img.rows ? img.at<T>(sy, sx) : fill;
    }
}

// Called by the fake camera's stream thread for each frame, the buffer's geometry already set.
void fill(ArvBuffer* buffer, void* data, guint32, guint32, ArvPixelFormat format) {
  auto* s = static_cast<Served*>(data);
  const long n = static_cast<long>(s->strains.size());
  const long state = std::min(s->filled / s->hold, n - 1);
  ++s->filled;
  const int w = arv_buffer_get_image_width(buffer), h = arv_buffer_get_image_height(buffer);
  const int x0 = arv_buffer_get_image_x(buffer), y0 = arv_buffer_get_image_y(buffer);
  const std::size_t bytes = format == ARV_PIXEL_FORMAT_MONO_16 ? 2 : 1;
  const std::size_t need = static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * bytes;
  // The stream thread's buffer holds the payload the camera announced when streaming began.
  if (w <= 0 || h <= 0 || x0 < 0 || y0 < 0 || need > arv_fake_camera_get_payload(s->camera)) {
    std::fprintf(s->log, "%llu,-1,nan\n", static_cast<unsigned long long>(arv_buffer_get_frame_id(buffer)));
    std::fflush(s->log);
    return;
  }
  // The fill callback writes the buffer's data (as Aravis' own patterns do).
  void* out = const_cast<void*>(arv_buffer_get_data(buffer, nullptr));
  const auto k = static_cast<std::size_t>(state);
  if (format == ARV_PIXEL_FORMAT_MONO_16)
    cut<std::uint16_t>(s->mono16[k], static_cast<std::uint16_t>(s->background * 257), x0, y0, w, h,
                       static_cast<std::uint16_t*>(out));
  else if (format == ARV_PIXEL_FORMAT_MONO_8)
    cut<std::uint8_t>(s->mono8[k], static_cast<std::uint8_t>(s->background), x0, y0, w, h,
                      static_cast<std::uint8_t*>(out));
  else
    std::memset(out, 0, need);  // a format this helper does not draw: a flat image
  std::fprintf(s->log, "%llu,%ld,%.9g\n", static_cast<unsigned long long>(arv_buffer_get_frame_id(buffer)),
               format == ARV_PIXEL_FORMAT_MONO_16 || format == ARV_PIXEL_FORMAT_MONO_8 ? state : -1L,
               s->strains[k]);
  std::fflush(s->log);
}

std::vector<double> parse_list(const std::string& v) {
  std::vector<double> out;
  std::stringstream in(v);
  for (std::string item; std::getline(in, item, ',');) out.push_back(std::stod(item));
  if (out.empty()) throw std::invalid_argument("strains: give one or more, e.g. 0,1e-3,2e-3");
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || std::string(argv[1]) == "--help") {
    std::fprintf(stderr,
                 "usage: fake_dot_camera SERIAL LOG [interface=127.0.0.1 width=640 height=480 dots=160 radius=6 "
                 "gap=8 seed=7 noise=0 nu=0.3 strains=0,1e-3,2e-3 hold=3]\n");
    return 2;
  }
  const std::string serial = argv[1];
  std::string iface = "127.0.0.1";
  Served served;
  served.strains = {0, 1e-3, 2e-3};
  dct_indep::Params p;
  p.width = 640;
  p.height = 480;
  p.dots = 160;
  p.radius = 6;
  p.min_gap = 8;
  p.seed = 7;
  p.noise = 0;
  p.deformation = "tension";
  try {
    for (int i = 3; i < argc; ++i) {
      const std::string a = argv[i];
      const auto eq = a.find('=');
      if (eq == std::string::npos) throw std::invalid_argument("'" + a + "' is not key=value");
      const std::string k = a.substr(0, eq), v = a.substr(eq + 1);
      if (k == "interface") iface = v;
      else if (k == "width") p.width = std::stoi(v);
      else if (k == "height") p.height = std::stoi(v);
      else if (k == "dots") p.dots = std::stoi(v);
      else if (k == "radius") p.radius = std::stod(v);
      else if (k == "gap") p.min_gap = std::stod(v);
      else if (k == "seed") p.seed = std::stoull(v);
      else if (k == "noise") p.noise = std::stod(v);
      else if (k == "nu") p.nu = std::stod(v);
      else if (k == "strains") served.strains = parse_list(v);
      else if (k == "hold") served.hold = std::stol(v);
      else throw std::invalid_argument("unknown key '" + k + "'");
    }
    if (served.hold < 1) throw std::invalid_argument("hold must be 1 or more frames");
    // One image per state; the dots' places depend on the seed only, so every state shows the
    // same pattern.
    for (std::size_t k = 0; k < served.strains.size(); ++k) {
      dct_indep::Params q = p;
      q.strain = served.strains[k];
      const dct_indep::Scene scene = dct_indep::make_scene(q);
      const cv::Mat clean = dct_indep::render_clean(scene, q.strain != 0);
      served.mono8.push_back(dct_indep::finish(clean, q.noise, q.seed * 2 + k));
      cv::Mat m16;
      clean.convertTo(m16, CV_16U, 257.0);  // rounded to the nearest level
      served.mono16.push_back(m16);
    }
    served.background = p.background;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fake_dot_camera: %s\n", e.what());
    return 2;
  }
  served.log = std::fopen(argv[2], "w");
  if (!served.log) {
    std::fprintf(stderr, "fake_dot_camera: cannot write %s\n", argv[2]);
    return 2;
  }
  // The camera's threads inherit this mask: the signals are taken here, by sigwait.
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGTERM);
  sigaddset(&stop, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);

  ArvGvFakeCamera* gv = arv_gv_fake_camera_new(iface.c_str(), serial.c_str());
  if (gv == nullptr || !arv_gv_fake_camera_is_running(gv)) {
    std::fprintf(stderr, "fake_dot_camera: the fake camera does not listen on %s (GVCP port 3956 taken, or no such "
                         "interface)\n", iface.c_str());
    if (gv) g_object_unref(gv);
    return 1;
  }
  served.camera = arv_gv_fake_camera_get_fake_camera(gv);
  arv_fake_camera_set_fill_pattern(served.camera, fill, &served);
  std::printf("ready Aravis-Fake-%s (%zu states, %ld frames each, %dx%d, %zu dots)\n", serial.c_str(),
              served.strains.size(), served.hold, p.width, p.height, static_cast<std::size_t>(p.dots));
  std::fflush(stdout);
  int sig = 0;
  sigwait(&stop, &sig);
  g_object_unref(gv);  // stops the camera's thread
  std::fclose(served.log);
  return 0;
}
