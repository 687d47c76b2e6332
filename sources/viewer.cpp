#include "sources/viewer.hpp"

#include <mutex>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <httplib.h>
#include <opencv2/imgcodecs.hpp>

#include "model/errors.hpp"

namespace dtflop::live {
namespace {

// The page: polls status.json and, when the frame changes, reloads the image.
constexpr const char* kPage = R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>dtflop live</title>
<style>body{font-family:sans-serif;margin:12px;background:#fff}#status{margin:6px 0;font-size:15px}
img{max-width:100%;border:1px solid #ccc}</style></head>
<body><h1 style="font-size:18px">dtflop live: DCT fields</h1>
<div id="status">waiting for the first frame...</div>
<img id="field" alt="field">
<script>
let shown = -1;
async function poll() {
  try {
    const s = await (await fetch('status.json', {cache: 'no-store'})).json();
    if (s.frame !== undefined) {
      document.getElementById('status').textContent =
        'frame ' + s.frame + ' | ' + (s.fps ? s.fps.toFixed(2) : '-') + ' frames/s | latency ' +
        (1e3 * s.latency_s).toFixed(1) + ' ms | deadline margin ' +
        (s.margin_s === null || s.margin_s === undefined ? '-' : (1e3 * s.margin_s).toFixed(1) + ' ms') +
        ' | dropped ' + s.dropped + ' | ' + s.field;
      if (s.frame !== shown) { shown = s.frame; document.getElementById('field').src = 'field.png?frame=' + s.frame; }
    }
  } catch (e) {}
  setTimeout(poll, 250);
}
poll();
</script></body></html>
)";

}  // namespace

struct Viewer::Impl {
  httplib::Server server;
  std::thread thread;
  std::mutex mutex;
  std::string png;
  std::string status = "{}";
  int port = 0;
};

Viewer::Viewer(int port) : impl_(std::make_unique<Impl>()) {
  if (port < 1024 || port > 65535)
    throw InputError(fmt::format("--serve {}: give a port in 1024..65535", port));
  impl_->port = port;
  Impl* d = impl_.get();
  d->server.Get("/", [](const httplib::Request&, httplib::Response& res) { res.set_content(kPage, "text/html"); });
  d->server.Get("/status.json", [d](const httplib::Request&, httplib::Response& res) {
    std::lock_guard lock(d->mutex);
    res.set_header("Cache-Control", "no-store");
    res.set_content(d->status, "application/json");
  });
  d->server.Get("/field.png", [d](const httplib::Request&, httplib::Response& res) {
    std::lock_guard lock(d->mutex);
    if (d->png.empty()) {
      res.status = 503;
      return;
    }
    res.set_header("Cache-Control", "no-store");
    res.set_content(d->png, "image/png");
  });
  if (!d->server.bind_to_port("127.0.0.1", port))
    throw InputError(fmt::format("--serve {}: cannot listen on 127.0.0.1:{} (in use?); give another port", port, port));
  d->thread = std::thread([d] { d->server.listen_after_bind(); });
}

Viewer::~Viewer() {
  impl_->server.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

void Viewer::publish(const cv::Mat& image, const nlohmann::json& status) {
  std::vector<unsigned char> buf;
  cv::imencode(".png", image, buf, {cv::IMWRITE_PNG_COMPRESSION, 1});
  std::lock_guard lock(impl_->mutex);
  impl_->png.assign(buf.begin(), buf.end());
  impl_->status = status.dump();
}

std::string Viewer::url() const { return fmt::format("http://127.0.0.1:{}/", impl_->port); }

}  // namespace dtflop::live
