// GenICam cameras (GigE Vision, USB3 Vision) through Aravis 0.8's C API.
#include <chrono>
#include <algorithm>
#include <cmath>
#include <thread>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "sources/frame_source.hpp"
#include "sources/opencv_source.hpp"
#include "sources/pixels.hpp"

#ifdef DTFLOP_HAVE_ARAVIS
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>
extern "C" {
#include <arv.h>
}
#endif

namespace dtflop::sources {

#ifdef DTFLOP_HAVE_ARAVIS
namespace {

// A GError's message, freed.
std::string take(GError*& e) {
  std::string m = e ? e->message : "unknown error";
  if (e) g_error_free(e);
  e = nullptr;
  return m;
}

// The local IPv4 address the host sends from to reach `device` (a UDP socket connected to it
// sends nothing); empty when there is none.
std::string route_to(const std::string& device) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(3956);  // GVCP
  if (::inet_pton(AF_INET, device.c_str(), &to.sin_addr) != 1) return {};
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return {};
  std::string out;
  sockaddr_in from{};
  socklen_t len = sizeof from;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&from), &len) == 0) {
    char text[INET_ADDRSTRLEN] = {};
    if (::inet_ntop(AF_INET, &from.sin_addr, text, sizeof text)) out = text;
  }
  ::close(fd);
  return out;
}

class AravisSource final : public FrameSource {
 public:
  explicit AravisSource(const SourceSpec& s) : FrameSource(s) { open(); }
  ~AravisSource() override { close(); }

  std::string describe() const override {
    return fmt::format("Aravis camera '{}' ({} {}, {}x{} {}{})", id_, vendor_, model_, width_, height_, format_,
                       fps_ > 0 ? fmt::format(", {:.3g} fps", fps_) : "");
  }

 protected:
  Grab grab(Frame& f, std::string& why) override {
    // The first frame after opening may take longer (stream set-up, packet size negotiation).
    const double timeout_s = awaiting_first_ ? std::max(spec_.timeout_s, 5.0) : spec_.timeout_s;
    const auto timeout_us = static_cast<guint64>(timeout_s * 1e6);
    const double start = steady_seconds();
    for (;;) {
      ArvBuffer* b = arv_stream_timeout_pop_buffer(stream_, timeout_us);
      if (b == nullptr) {
        why = fmt::format("camera '{}' sent no frame for {:.3g} s (unplugged, powered off or its link lost)", id_,
                          timeout_s);
        close(true);
        return Grab::lost;
      }
      const ArvBufferStatus st = arv_buffer_get_status(b);
      if (st != ARV_BUFFER_STATUS_SUCCESS) {
        // A damaged frame is not given out; its id leaves a gap that next() counts as dropped.
        ++incomplete_;
        arv_stream_push_buffer(stream_, b);
        if (steady_seconds() - start > timeout_s) {
          why = fmt::format("camera '{}' sent only damaged frames for {:.3g} s", id_, timeout_s);
          close(true);
          return Grab::lost;
        }
        continue;
      }
      std::size_t size = 0;
      const void* data = arv_buffer_get_image_data(b, &size);
      const int w = arv_buffer_get_image_width(b), h = arv_buffer_get_image_height(b);
      try {
        f.image = to_grey(data, size, w, h, layout_);
      } catch (...) {
        arv_stream_push_buffer(stream_, b);
        throw;
      }
      f.bits = layout_.bits;
      f.sequence = arv_buffer_get_frame_id(b);
      f.timestamp_s = static_cast<double>(arv_buffer_get_timestamp(b)) * 1e-9;
      f.arrival_s = steady_seconds();
      arv_stream_push_buffer(stream_, b);
      awaiting_first_ = false;
      return Grab::frame;
    }
  }
  void reopen() override { open(); }
  std::uint64_t take_source_losses(std::uint64_t& incomplete) override {
    incomplete = incomplete_;
    incomplete_ = 0;
    return 0;  // the lost frames' ids are gaps that next() counts
  }
  double nominal_fps() const override { return fps_; }

 private:
  void check(GError*& e, const std::string& what) {
    if (e) {
      const std::string m = take(e);
      close();
      throw InputError(fmt::format("source '{}': {}: {}", spec_.text, what, m));
    }
  }

  void open() {
    close();
    GError* e = nullptr;
    // A GigE Vision camera named by its id is opened through the local address that routes to
    // it: on a host with several interfaces Aravis may take the discovery answer from any of
    // them, and a camera opened through the wrong one streams to an address it cannot reach.
    // The target is a GigE camera's IPv4 address, or an id looked up among the cameras
    // discovery finds (twice: a camera that has just come up may miss the first).
    std::string address;
    bool listed = false;
    in_addr probe{};
    if (::inet_pton(AF_INET, spec_.target.c_str(), &probe) == 1) {
      address = spec_.target;
      listed = true;
    }
    for (int round = 0; round < 2 && !listed && !spec_.target.empty(); ++round) {
      arv_update_device_list();
      for (unsigned i = 0; i < arv_get_n_devices(); ++i) {
        const char* id = arv_get_device_id(i);
        if (!id || spec_.target != id) continue;
        listed = true;
        const char* protocol = arv_get_device_protocol(i);
        const char* a = arv_get_device_address(i);
        if (protocol && std::string(protocol) == "GigEVision" && a) address = a;
      }
    }
    if (!spec_.target.empty() && !listed) {
      std::string list;
      for (unsigned i = 0; i < arv_get_n_devices(); ++i)
        list += fmt::format("{}{}", list.empty() ? "" : ", ", arv_get_device_id(i));
      throw InputError(fmt::format("source '{}': no camera '{}' found; cameras seen: {}; check its cable and power "
                                   "or give one of those ids",
                                   spec_.text, spec_.target, list.empty() ? "none" : list));
    }
    const std::string local = address.empty() ? std::string() : route_to(address);
    if (!local.empty()) {
      GInetAddress* iface = g_inet_address_new_from_string(local.c_str());
      GInetAddress* dev = g_inet_address_new_from_string(address.c_str());
      ArvDevice* device = arv_gv_device_new(iface, dev, &e);
      g_object_unref(iface);
      g_object_unref(dev);
      if (device) {
        camera_ = arv_camera_new_with_device(device, &e);
        g_object_unref(device);  // the camera holds its own reference
      }
    } else {
      camera_ = arv_camera_new(spec_.target.empty() ? nullptr : spec_.target.c_str(), &e);
    }
    if (camera_ == nullptr) {
      arv_update_device_list();
      std::string list;
      for (unsigned i = 0; i < arv_get_n_devices(); ++i)
        list += fmt::format("{}{}", list.empty() ? "" : ", ", arv_get_device_id(i));
      const std::string m = take(e);
      throw InputError(fmt::format("source '{}': no camera '{}' ({}); cameras seen: {}; check its cable and power or "
                                   "give one of those ids",
                                   spec_.text, spec_.target.empty() ? "(the first)" : spec_.target, m,
                                   list.empty() ? "none" : list));
    }
    id_ = spec_.target.empty() ? "(first)" : spec_.target;
    vendor_ = arv_camera_get_vendor_name(camera_, nullptr) ? arv_camera_get_vendor_name(camera_, nullptr) : "";
    model_ = arv_camera_get_model_name(camera_, nullptr) ? arv_camera_get_model_name(camera_, nullptr) : "";
    if (!spec_.pixel_format.empty()) {
      if (pixel_layout(spec_.pixel_format).format == PixelFormat::unsupported)
        throw InputError(fmt::format("source '{}': format={} is not one dtflop reads; use Mono8, Mono10, Mono12, "
                                     "Mono14, Mono16, Mono12Packed, Mono12p or a Bayer format (BayerRG8, BayerRG12, ...)",
                                     spec_.text, spec_.pixel_format));
      arv_camera_set_pixel_format_from_string(camera_, spec_.pixel_format.c_str(), &e);
      check(e, fmt::format("the camera refuses pixel format {}", spec_.pixel_format));
    }
    if (spec_.roi) {
      arv_camera_set_region(camera_, spec_.roi->x, spec_.roi->y, spec_.roi->width, spec_.roi->height, &e);
      check(e, "the camera refuses the ROI");
    }
    if (spec_.exposure_us) {
      arv_camera_set_exposure_time(camera_, *spec_.exposure_us, &e);
      check(e, "the camera refuses the exposure");
    }
    if (spec_.gain_db) {
      arv_camera_set_gain(camera_, *spec_.gain_db, &e);
      check(e, "the camera refuses the gain");
    }
    if (spec_.fps) {
      arv_camera_set_frame_rate(camera_, *spec_.fps, &e);
      check(e, "the camera refuses the frame rate");
    }
    const char* fmt_name = arv_camera_get_pixel_format_as_string(camera_, &e);
    check(e, "cannot read the pixel format");
    format_ = fmt_name ? fmt_name : "";
    layout_ = pixel_layout(format_);
    if (layout_.format == PixelFormat::unsupported) {
      close();
      throw InputError(fmt::format("source '{}': the camera sends {} pixels, which dtflop does not read; add "
                                   "format=Mono8 (or Mono16, a Bayer format) to the source",
                                   spec_.text, format_));
    }
    gint x = 0, y = 0;
    arv_camera_get_region(camera_, &x, &y, &width_, &height_, &e);
    check(e, "cannot read the region");
    fps_ = arv_camera_get_frame_rate(camera_, nullptr);
    const guint payload = arv_camera_get_payload(camera_, &e);
    check(e, "cannot read the payload size");
    if (payload == 0 || payload > (1u << 30)) {
      close();
      throw InputError(fmt::format("source '{}': the camera announces {} bytes a frame; set a smaller ROI", spec_.text,
                                   payload));
    }
    stream_ = arv_camera_create_stream(camera_, nullptr, nullptr, &e);
    check(e, "cannot open its stream");
    for (int i = 0; i < std::max(spec_.buffer, 2); ++i) arv_stream_push_buffer(stream_, arv_buffer_new(payload, nullptr));
    arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &e);
    check(e, "cannot set continuous acquisition");
    awaiting_first_ = true;
    arv_camera_start_acquisition(camera_, &e);
    check(e, "cannot start acquisition");
  }

  // `gone`: the camera no longer answers. Its stream and device are then released on a thread
  // of their own: releasing them writes to the camera, and each write waits out its timeouts
  // (~8 s in all), which would hold up the run that is ending or reopening.
  void close(bool gone = false) {
    if (gone && (camera_ || stream_)) {
      std::thread([s = stream_, c = camera_] {
        if (s) g_object_unref(s);
        if (c) g_object_unref(c);
      }).detach();
    } else {
      if (camera_ && stream_) arv_camera_stop_acquisition(camera_, nullptr);
      if (stream_) g_object_unref(stream_);
      if (camera_) g_object_unref(camera_);
    }
    stream_ = nullptr;
    camera_ = nullptr;
  }

  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  std::string id_, vendor_, model_, format_;
  PixelLayout layout_;
  gint width_ = 0, height_ = 0;
  double fps_ = 0;
  std::uint64_t incomplete_ = 0;
  bool awaiting_first_ = true;
};

}  // namespace

std::unique_ptr<FrameSource> open_aravis_source(const SourceSpec& spec) { return std::make_unique<AravisSource>(spec); }
bool have_aravis() { return true; }

#else

std::unique_ptr<FrameSource> open_aravis_source(const SourceSpec& spec) {
  throw InputError(fmt::format("source '{}': this dtflop was built without Aravis; install libaravis-dev "
                               "(scripts/setup.sh does) and rebuild",
                               spec.text));
}
bool have_aravis() { return false; }

#endif

std::unique_ptr<FrameSource> open_source(const SourceSpec& spec) {
  if (spec.kind == SourceSpec::Kind::aravis) return open_aravis_source(spec);
  return open_opencv_source(spec);
}

}  // namespace dtflop::sources
