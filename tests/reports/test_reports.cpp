// Reports: the axis ticks, the files write_report() makes and refuses to replace, and each kind
// of report made by `dtflop report` from archived stores and profiles, checked as a person would
// see it: opened in headless Chromium, screenshot, and every chart's SVG marks (their count and
// their data-x/data-y values) checked against the rows of its CSV file. The checks parse the
// HTML and CSV here with their own code, not with the renderer's.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "model/errors.hpp"
#include "model/stats.hpp"
#include "probes/machine.hpp"
#include "reports/document.hpp"
#include "reports/reports.hpp"
#include "tests/cli/run_cli.hpp"
#include "tests/support/temp_dir.hpp"

namespace dtflop {
namespace {

namespace fs = std::filesystem;
using reports::ticks;
using reports::tick_label;

TEST(ReportTicks, LogAxesGetDecadesAndLinearAxesOneTwoFiveSteps) {
  EXPECT_EQ(ticks(3e3, 4e8, true), (std::vector<double>{1e4, 1e5, 1e6, 1e7, 1e8}));
  // Under a decade and a half: 1-2-5 within it.
  EXPECT_EQ(ticks(1.5e-5, 9e-5, true), (std::vector<double>{2e-5, 5e-5}));
  const auto unit = ticks(0, 1, false);
  ASSERT_EQ(unit.size(), 6u);
  for (std::size_t i = 0; i < unit.size(); ++i) EXPECT_NEAR(unit[i], 0.2 * static_cast<double>(i), 1e-12);
  const auto lin = ticks(-3, 47, false);
  ASSERT_GE(lin.size(), 3u);
  for (std::size_t i = 1; i < lin.size(); ++i) EXPECT_NEAR(lin[i] - lin[i - 1], 10, 1e-9);
  EXPECT_NEAR(lin.front(), 0, 1e-12);
}

TEST(ReportTicks, LabelsAreShortWithSiPrefixes) {
  EXPECT_EQ(tick_label(0), "0");
  EXPECT_EQ(tick_label(1e4), "10 k");
  EXPECT_EQ(tick_label(2.5e9), "2.5 G");
  EXPECT_EQ(tick_label(1e-5), "10 µ");
  EXPECT_EQ(tick_label(0.25), "0.25");
  EXPECT_EQ(tick_label(3), "3");
}

reports::Document tiny_document() {
  reports::Document d;
  d.kind = "test";
  d.title = "A <tiny> report";
  d.stamp = {"test machine", "2026-11-24", "2026-11-24", "test", "dtflop report test", {}};
  reports::Chart c;
  c.id = "tiny";
  c.title = "y against x";
  c.x = {"x [B]", true};
  c.y = {"y [s]", true};
  c.series.push_back({"measured", reports::SeriesKind::points, 0, {{1e3, 1e-5, "a, \"quoted\""}, {1e4, 2e-5, ""}, {1e5, 9e-5, ""}}});
  c.series.push_back({"predicted", reports::SeriesKind::line, 0, {{1e3, 1.1e-5, ""}, {1e5, 8e-5, ""}}});
  d.sections.push_back({"Section", {reports::Paragraph{"text | with a bar"}, c}});
  return d;
}

TEST(ReportFiles, WritesHtmlMarkdownAndACsvPerChartAndNeverReplacesAFolder) {
  const auto dir = test::fresh_test_dir("dtflop_reports");
  const auto out = dir / "r";
  const auto html = reports::write_report(tiny_document(), out);
  EXPECT_EQ(html, out / "report.html");
  const std::string page = test::slurp(html);
  EXPECT_NE(page.find("A &lt;tiny&gt; report"), std::string::npos);
  EXPECT_EQ(page.find("http://"), page.find("http://www.w3.org/2000/svg"));  // nothing fetched: the SVG namespace only
  EXPECT_EQ(page.find("<script"), std::string::npos);
  const std::string csv = test::slurp(out / "01-tiny.csv");
  EXPECT_EQ(test::count_lines(csv), 1 + 3 + 2);
  EXPECT_NE(csv.find("\"a, \"\"quoted\"\"\""), std::string::npos);
  EXPECT_NE(test::slurp(out / "report.md").find("text | with a bar"), std::string::npos);
  // A second report into the same folder is refused, and the first is untouched.
  EXPECT_THROW(reports::write_report(reports::Document{}, out), InputError);
  EXPECT_EQ(test::slurp(html), page);
  // So is a link, even to nowhere.
  fs::create_symlink(dir / "nowhere", dir / "link");
  EXPECT_THROW(reports::write_report(tiny_document(), dir / "link"), InputError);
  EXPECT_FALSE(fs::exists(dir / "nowhere"));
  fs::remove_all(dir);
}

// The probe keeps every transfer size it measured in the profile, and the machine report draws
// them over the fitted curve: one point per size at bytes / median seconds.
TEST(MachineReport, DrawsTheProbedTransferSizesOverTheFit) {
  probes::MachineReport mr;
  mr.identity.cpu_model = "test CPU";
  mr.identity.cpu_threads = 4;
  mr.identity.gpu_name = "test GPU";
  probes::ProbeReport pr;
  pr.probe = "gpu-transfers";
  const double L = 4e-6, B = 20e9;
  const std::vector<double> sizes = {4096, 1 << 20, 64 << 20};
  for (double bytes : sizes) {
    probes::Measurement m;
    const double t = L + bytes / B;
    m.key = fmt::format("h2d_pinned_{}", static_cast<long long>(bytes));
    m.unit = "B/s";
    m.stats = summarize(std::vector<double>{t * 0.99, t, t * 1.02});
    m.value = bytes / m.stats.median;
    m.detail = true;
    pr.measurements.push_back(m);
  }
  probes::Measurement b;
  b.key = "h2d_pinned_bandwidth";
  b.unit = "B/s";
  b.value = B;
  b.param = Param::B_CG_pinned;
  pr.measurements.push_back(b);
  probes::Measurement l = b;
  l.key = "h2d_pinned_latency";
  l.unit = "s";
  l.value = L;
  l.param = Param::L_CG_pinned;
  pr.measurements.push_back(l);
  mr.reports.push_back(pr);
  const MachineProfile p = probes::make_profile(mr);

  const auto points = reports::decode_transfer_points(p.metadata.at("probe.transfers.h2d_pinned"));
  ASSERT_EQ(points.size(), sizes.size());
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    EXPECT_DOUBLE_EQ(points[i].first, sizes[i]);
    EXPECT_NEAR(points[i].second, L + sizes[i] / B, 1e-9 * points[i].second);
  }
  EXPECT_TRUE(reports::decode_transfer_points("4096:x").empty());
  EXPECT_TRUE(reports::decode_transfer_points("4096:-1").empty());

  const reports::Document d = reports::machine_report(p, {"test", {}});
  const reports::Chart* h2d = nullptr;
  for (const auto* c : reports::charts(d))
    if (c->id == "transfers-h2d") h2d = c;
  ASSERT_NE(h2d, nullptr);
  const std::string csv = reports::render_csv(*h2d);
  int measured = 0;
  for (const auto& s : h2d->series)
    if (s.kind == reports::SeriesKind::points) {
      ++measured;
      ASSERT_EQ(s.points.size(), sizes.size());
      for (std::size_t i = 0; i < sizes.size(); ++i) EXPECT_NEAR(s.points[i].y, B * sizes[i] / (L * B + sizes[i]), 1e-6 * B);
    } else {
      // The fitted curve n / (L + n/B) and its asymptote B: never above B.
      for (const auto& pt : s.points) EXPECT_LE(pt.y, B * (1 + 1e-12));
    }
  EXPECT_EQ(measured, 1);
  EXPECT_EQ(test::count_lines(csv), 1 + 3 + 49 + 2);
}

// ---- Every report kind, from archived files, rendered by Chromium --------------------------

struct CsvRow {
  std::string series, kind;
  double x, y;
};

// A minimal CSV reader for the report's files (quoted fields with doubled quotes).
std::vector<CsvRow> read_csv(const fs::path& p) {
  std::vector<CsvRow> rows;
  std::istringstream in(test::slurp(p));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "series,kind,x,y,label") << p;
  while (std::getline(in, line)) {
    std::vector<std::string> f(1);
    bool q = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
      const char c = line[i];
      if (q && c == '"' && i + 1 < line.size() && line[i + 1] == '"') f.back() += '"', ++i;
      else if (c == '"') q = !q;
      else if (c == ',' && !q) f.emplace_back();
      else f.back() += c;
    }
    EXPECT_EQ(f.size(), 5u) << line;
    if (f.size() != 5) continue;
    rows.push_back({f[0], f[1], std::stod(f[2]), std::stod(f[3])});
  }
  return rows;
}

std::string attr(const std::string& tag, const std::string& name) {
  std::smatch m;
  const std::regex re(" " + name + "=\"([^\"]*)\"");
  return std::regex_search(tag, m, re) ? m[1].str() : std::string();
}

struct ChartMarks {
  std::string id;
  std::vector<std::pair<double, double>> marks;  // circles and bars: their data-x, data-y
  int line_vertices = 0;                         // vertices of every polyline
};

// The charts of a rendered page, in order, with what each drew.
std::vector<ChartMarks> charts_in(const std::string& dom) {
  std::vector<ChartMarks> out;
  const std::regex tag_re("<(svg|circle|rect|polyline)\\b[^>]*>");
  for (auto it = std::sregex_iterator(dom.begin(), dom.end(), tag_re); it != std::sregex_iterator(); ++it) {
    const std::string tag = it->str();
    const std::string name = (*it)[1].str();
    if (name == "svg" && tag.find("class=\"chart\"") != std::string::npos) {
      out.push_back({attr(tag, "data-chart"), {}, 0});
    } else if (!out.empty() && (name == "circle" || name == "rect") && tag.find("class=\"mark\"") != std::string::npos) {
      out.back().marks.emplace_back(std::stod(attr(tag, "data-x")), std::stod(attr(tag, "data-y")));
    } else if (!out.empty() && name == "polyline") {
      std::istringstream pts(attr(tag, "points"));
      std::string v;
      while (pts >> v) ++out.back().line_vertices;
    }
  }
  return out;
}

std::string chromium() {
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (fs::exists(p)) return p;
  return {};
}

// Opens the report in headless Chromium: the DOM it rendered, and a screenshot (PNG).
std::string open_in_chromium(const std::string& browser, const fs::path& html, const fs::path& png, const fs::path& dir) {
  const std::string flags = fmt::format("--headless --no-sandbox --disable-gpu --hide-scrollbars --user-data-dir={} ",
                                        (dir / "profile").string());
  const std::string url = "file://" + fs::absolute(html).string();
  const std::string dom_cmd = fmt::format("{} {} --dump-dom {} >{} 2>{}", browser, flags, url, (dir / "dom.html").string(),
                                          (dir / "chromium.log").string());
  EXPECT_EQ(std::system(dom_cmd.c_str()), 0) << test::slurp(dir / "chromium.log");
  fs::remove_all(dir / "profile");
  const std::string shot_cmd = fmt::format("{} {} --window-size=1100,1600 --screenshot={} {} >>{} 2>&1", browser, flags,
                                           png.string(), url, (dir / "chromium.log").string());
  EXPECT_EQ(std::system(shot_cmd.c_str()), 0) << test::slurp(dir / "chromium.log");
  fs::remove_all(dir / "profile");
  return test::slurp(dir / "dom.html");
}

// Checks a report folder as rendered by Chromium: every chart of the page has its CSV, draws one
// mark per row of its measured/bar series (same values) and one polyline vertex per row of its
// line series; the screenshot is a PNG of the window's size with content.
void check_rendered(const fs::path& folder, const fs::path& dir, const std::string& browser, int min_charts) {
  const std::string dom = open_in_chromium(browser, folder / "report.html", dir / "shot.png", dir);
  ASSERT_NE(dom.find("</html>"), std::string::npos) << "Chromium returned no page";
  const auto charts = charts_in(dom);
  ASSERT_GE(static_cast<int>(charts.size()), min_charts);
  int index = 0;
  for (const auto& c : charts) {
    ++index;
    const fs::path csv = folder / fmt::format("{:02d}-{}.csv", index, c.id);
    ASSERT_TRUE(fs::exists(csv)) << csv;
    const auto rows = read_csv(csv);
    std::multiset<std::pair<double, double>> expected_marks, drawn(c.marks.begin(), c.marks.end());
    int line_rows = 0;
    for (const auto& r : rows) {
      if (r.kind == "line") ++line_rows;
      else expected_marks.insert({r.x, r.y});
    }
    EXPECT_FALSE(rows.empty()) << csv;
    EXPECT_EQ(drawn, expected_marks) << csv;
    EXPECT_EQ(c.line_vertices, line_rows) << csv;
  }
  // The screenshot: a PNG whose header says 1100 x 1600, holding more than a blank page.
  const std::string png = test::slurp(dir / "shot.png");
  ASSERT_GT(png.size(), 24u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  auto be32 = [&](std::size_t at) {
    return (static_cast<unsigned char>(png[at]) << 24) | (static_cast<unsigned char>(png[at + 1]) << 16) |
           (static_cast<unsigned char>(png[at + 2]) << 8) | static_cast<unsigned char>(png[at + 3]);
  };
  EXPECT_EQ(be32(16), 1100u);
  EXPECT_EQ(be32(20), 1600u);
  EXPECT_GT(png.size(), 30000u) << "the screenshot looks blank";
}

class ReportKinds : public ::testing::Test {
 protected:
  void SetUp() override {
    browser_ = chromium();
    dir_ = test::fresh_test_dir("dtflop_report_kinds");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string browser_;
  fs::path dir_;
};

TEST_F(ReportKinds, MachineReportOfAnArchivedProfile) {
  const auto out = dir_ / "machine";
  const auto r = test::run_dtflop("report machine --machine " +
                                  test::source_path("results/rbe-calibration/h200-2026-11-24/probed.json") + " -o " +
                                  out.string());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.substr(0, r.out.find('\n')), (out / "report.html").string());
  const std::string page = test::slurp(out / "report.html");
  for (const char* s : {"NVIDIA H200", "dtflop version", "dtflop report machine", "host-&gt;device copies"})
    EXPECT_NE(page.find(s), std::string::npos) << s;
  if (browser_.empty()) GTEST_SKIP() << "chromium is not installed (scripts/test.sh installs it): not rendered";
  check_rendered(out, dir_, browser_, 4);
}

TEST_F(ReportKinds, PredictedReportOfArchivedStores) {
  if (std::system("command -v xz >/dev/null 2>&1") != 0) GTEST_SKIP() << "xz is not installed: cannot read the archived store";
  const auto store = dir_ / "held.jsonl";
  ASSERT_EQ(std::system(fmt::format("xz -dc {} > {}", test::source_path("results/dct-calibration/cpu-2026-11-24/held.jsonl.xz"),
                                    store.string())
                            .c_str()),
            0);
  const auto out = dir_ / "predicted";
  const std::string profile = test::source_path("results/dct-calibration/cpu-2026-11-24/fitted-cpu-par.json");
  const auto r = test::run_dtflop(fmt::format("report predicted --store {} --machine {} --backend cpu-par -o {}",
                                              store.string(), profile, out.string()));
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string md = test::slurp(out / "report.md");
  for (const char* s : {"mean rel", "Worst configurations", "Which variant won", "| fitted |"})
    EXPECT_NE(md.find(s), std::string::npos) << s;
  // Bad input: the same folder again, and a store without samples: exit 2, one line, nothing written.
  const std::string before = test::slurp(out / "report.html");
  const auto again = test::run_dtflop(fmt::format("report predicted --store {} --machine {} -o {}", store.string(), profile,
                                                  out.string()));
  EXPECT_EQ(again.status, 2);
  EXPECT_EQ(test::count_lines(again.err), 1) << again.err;
  EXPECT_EQ(test::slurp(out / "report.html"), before);
  const auto empty = dir_ / "empty.jsonl";
  { std::ofstream(empty.string()); }
  const auto none = test::run_dtflop(fmt::format("report predicted --store {} --machine {} -o {}", empty.string(), profile,
                                                 (dir_ / "none").string()));
  EXPECT_EQ(none.status, 2);
  EXPECT_NE(none.err.find("holds no samples"), std::string::npos) << none.err;
  EXPECT_FALSE(fs::exists(dir_ / "none"));
  // Samples of two machines in one chart: refused.
  ASSERT_EQ(std::system(fmt::format("xz -dc {} | head -4 >> {}",
                                    test::source_path("results/dct-calibration/h100-2026-11-24/held.jsonl.xz"), store.string())
                            .c_str()),
            0);
  const auto mixed = test::run_dtflop(fmt::format("report predicted --store {} --machine {} -o {}", store.string(), profile,
                                                  (dir_ / "mixed").string()));
  EXPECT_EQ(mixed.status, 2);
  EXPECT_NE(mixed.err.find("two machines"), std::string::npos) << mixed.err;
  EXPECT_FALSE(fs::exists(dir_ / "mixed"));
  if (browser_.empty()) GTEST_SKIP() << "chromium is not installed (scripts/test.sh installs it): not rendered";
  check_rendered(out, dir_, browser_, 1);
}

TEST_F(ReportKinds, ComparisonOfTwoMachines) {
  const auto out = dir_ / "compare";
  const auto r = test::run_dtflop(fmt::format(
      "report compare --machine {} --machine {} --names H200,H100 -o {}",
      test::source_path("results/rbe-calibration/h200-2026-11-24/probed.json"),
      test::source_path("results/dct-calibration/h100-2026-11-24/probed.json"), out.string()));
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string md = test::slurp(out / "report.md");
  EXPECT_NE(md.find("Two machines"), std::string::npos);
  EXPECT_NE(md.find("| B_GG |"), std::string::npos);
  if (browser_.empty()) GTEST_SKIP() << "chromium is not installed (scripts/test.sh installs it): not rendered";
  check_rendered(out, dir_, browser_, 1);
}

TEST_F(ReportKinds, TuningReportOfAnArchivedTuning) {
  // The 2-core machine's RBE tuning (every valid configuration measured, strategies replayed) and
  // a peer's replay written here: the report draws each configuration, the result's Pareto front,
  // and one line per strategy.
  const std::string result = test::source_path("results/tuning/cpu-2026-11-24/rbe/replay.json");
  const auto j = nlohmann::json::parse(test::slurp(result));
  const auto peer = dir_ / "peer.json";
  std::ofstream(peer) << R"({"rows": [{"strategy": "peer", "budget": 5, "median_fraction_of_optimum": 0.5},
                                    {"strategy": "peer", "budget": 10, "median_fraction_of_optimum": 0.75}]})";
  const auto out = dir_ / "tuning";
  const auto r = test::run_dtflop(fmt::format("report tuning --result {} --peer {} -o {}", result, peer.string(), out.string()));
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string md = test::slurp(out / "report.md");
  EXPECT_NE(md.find("Chosen: " + j.at("chosen").at("label").get<std::string>()), std::string::npos) << md;
  // Every measured configuration is one point; the front, as the result holds it.
  const auto time_accuracy = read_csv(out / "01-time-accuracy.csv");
  std::size_t configurations = 0, front = 0;
  for (const auto& row : time_accuracy) {
    configurations += row.series == "configurations";
    front += row.series == "Pareto front";
  }
  EXPECT_EQ(configurations, j.at("configurations").size());
  EXPECT_EQ(front, j.at("pareto_front").size());
  // The chosen configuration is the fastest point drawn.
  double fastest = INFINITY;
  for (const auto& row : time_accuracy)
    if (row.series == "configurations") fastest = std::min(fastest, row.x);
  EXPECT_EQ(fastest, j.at("chosen").at("measured_seconds").get<double>());
  // One line per strategy: model, random and the peer.
  std::set<std::string> strategies;
  for (const auto& row : read_csv(out / "03-search.csv")) strategies.insert(row.series);
  EXPECT_EQ(strategies, (std::set<std::string>{"model", "peer", "random"}));
  // A file that is not a tuning result is refused in one line.
  const auto bad = test::run_dtflop(fmt::format("report tuning --result {} -o {}",
                                                test::source_path("docs/examples/h200.json"), (dir_ / "bad").string()));
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.err.find("dtflop.tuned"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir_ / "bad"));
  if (browser_.empty()) GTEST_SKIP() << "chromium is not installed (scripts/test.sh installs it): not rendered";
  check_rendered(out, dir_, browser_, 3);
}

TEST_F(ReportKinds, ComparisonOfTwoRuns) {
  if (std::system("command -v xz >/dev/null 2>&1") != 0) GTEST_SKIP() << "xz is not installed: cannot read the archived store";
  // Run A is the archived held-out store; run B the same samples with every time doubled.
  const auto a = dir_ / "a.jsonl", b = dir_ / "b.jsonl";
  ASSERT_EQ(std::system(fmt::format("xz -dc {} > {}", test::source_path("results/dct-calibration/cpu-2026-11-24/held.jsonl.xz"),
                                    a.string())
                            .c_str()),
            0);
  {
    std::ifstream in(a);
    std::ofstream out(b);
    std::string line;
    int n = 0;
    while (std::getline(in, line)) {
      auto j = nlohmann::json::parse(line);
      for (auto& [name, st] : j.at("components").items())
        for (const char* k : {"median", "p25", "p75", "min", "max", "mean"})
          if (st.contains(k)) st[k] = 2 * st[k].get<double>();
      for (auto& [name, st] : j.at("components").items())
        if (st.contains("values"))
          for (auto& v : st["values"]) v = 2 * v.get<double>();
      out << j.dump() << "\n";
      ++n;
    }
    ASSERT_GT(n, 0);
  }
  const auto out = dir_ / "runs";
  const auto r = test::run_dtflop(fmt::format("report compare --store-a {} --store-b {} --names before,after -o {}", a.string(),
                                              b.string(), out.string()));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("geometric mean 2,"), std::string::npos) << r.out;
  const auto rows = read_csv(out / "01-runs.csv");
  ASSERT_FALSE(rows.empty());
  for (const auto& row : rows) EXPECT_NEAR(row.y, 2 * row.x, 1e-12 * row.y);
  // Half a comparison is refused.
  const auto half = test::run_dtflop(fmt::format("report compare --store-a {} -o {}", a.string(), (dir_ / "half").string()));
  EXPECT_EQ(half.status, 2);
  EXPECT_FALSE(fs::exists(dir_ / "half"));
  if (browser_.empty()) GTEST_SKIP() << "chromium is not installed (scripts/test.sh installs it): not rendered";
  check_rendered(out, dir_, browser_, 1);
}

}  // namespace
}  // namespace dtflop
