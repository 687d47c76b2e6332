#include "reports/document.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <system_error>

#include <fmt/format.h>

#include "model/errors.hpp"
#include "model/json_io.hpp"

namespace dtflop::reports {
namespace {

namespace fs = std::filesystem;

// Okabe-Ito: told apart by readers with the common colour-vision deficiencies; yellow swapped
// for grey (too pale on white).
constexpr const char* kPalette[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                    "#E69F00", "#56B4E9", "#000000", "#999999"};

std::string esc(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string md_cell(std::string_view s) {
  std::string out;
  for (char c : s) {
    if (c == '|') out += "\\|";
    else if (c == '\n') out += ' ';
    else out += c;
  }
  return out;
}

std::string csv_field(std::string_view s) {
  if (s.find_first_of(",\"\n") == std::string_view::npos) return std::string(s);
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string num(double v) { return fmt::format("{:.17g}", v); }

// The coordinate system of one chart.
struct Frame {
  double x0, x1, y0, y1;  // data range
  bool xlog, ylog;
  double left = 84, top = 44, width = 600, height = 300;
  double px(double x) const {
    const double t = xlog ? (std::log10(x) - std::log10(x0)) / (std::log10(x1) - std::log10(x0)) : (x - x0) / (x1 - x0);
    return left + t * width;
  }
  double py(double y) const {
    const double t = ylog ? (std::log10(y) - std::log10(y0)) / (std::log10(y1) - std::log10(y0)) : (y - y0) / (y1 - y0);
    return top + height - t * height;
  }
};

void pad_range(double& lo, double& hi, bool log, bool from_zero) {
  if (log) {
    if (hi <= lo * 1.0001) {
      lo /= 2;
      hi *= 2;
    }
    const double f = std::pow(hi / lo, 0.05);
    lo /= f;
    hi *= f;
    return;
  }
  if (from_zero && lo > 0) lo = 0;
  if (hi - lo <= std::abs(hi) * 1e-9) {
    const double d = hi == 0 ? 1 : std::abs(hi) * 0.5;
    lo -= d;
    hi += d;
  }
  const double m = 0.05 * (hi - lo);
  if (!(from_zero && lo == 0)) lo -= m;
  hi += m;
}

}  // namespace

std::string colour(int i) {
  constexpr int n = sizeof(kPalette) / sizeof(kPalette[0]);
  return kPalette[((i % n) + n) % n];
}

std::vector<double> ticks(double lo, double hi, bool log) {
  std::vector<double> t;
  if (!(hi > lo)) return {lo, hi};
  if (log && lo > 0) {
    const int d0 = static_cast<int>(std::ceil(std::log10(lo) - 1e-9));
    const int d1 = static_cast<int>(std::floor(std::log10(hi) + 1e-9));
    const int decades = d1 - d0 + 1;
    const int step = decades > 8 ? 2 : 1;  // at most ~8 labels
    for (int d = d0; d <= d1; d += step) t.push_back(std::pow(10.0, d));
    if (t.size() < 3) {
      std::vector<double> more;
      for (int d = d0 - 1; d <= d1; ++d)
        for (double m : {1.0, 2.0, 5.0}) {
          const double v = m * std::pow(10.0, d);
          if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) more.push_back(v);
        }
      if (more.size() >= 2) t = more;
    }
    if (t.size() >= 2) return t;
    // Less than a factor of two: linear ticks read better.
  }
  const double raw = (hi - lo) / 5;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + step * 1e-9; v += step)
    t.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  if (t.size() < 2) t = {lo, hi};
  return t;
}

std::string tick_label(double v) {
  if (v == 0) return "0";
  struct Prefix {
    double scale;
    const char* name;
  };
  static const Prefix prefixes[] = {{1e12, " T"}, {1e9, " G"}, {1e6, " M"}, {1e3, " k"}, {1, ""},
                                    {1e-3, " m"}, {1e-6, " µ"}, {1e-9, " n"}, {1e-12, " p"}};
  const double a = std::abs(v);
  if (a >= 0.01 && a < 1000) return fmt::format("{:.3g}", v);  // 0.25, 3, 500: no prefix
  for (const auto& p : prefixes)
    if (a >= p.scale * (1 - 1e-9) || p.scale == 1e-12) return fmt::format("{:.3g}{}", v / p.scale, p.name);
  return fmt::format("{:.3g}", v);
}

std::string render_svg(const Chart& c) {
  const bool bars = std::any_of(c.series.begin(), c.series.end(), [](const Series& s) { return s.kind == SeriesKind::bars; });
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  bool xlog = c.x.log && !bars, ylog = c.y.log;
  for (const auto& s : c.series)
    for (const auto& p : s.points) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
      x0 = std::min(x0, p.x);
      x1 = std::max(x1, p.x);
      y0 = std::min(y0, p.y);
      y1 = std::max(y1, p.y);
      if (p.x <= 0) xlog = false;
      if (p.y <= 0) ylog = false;
    }
  if (!std::isfinite(x0)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  if (c.diagonal) {
    x0 = y0 = std::min(x0, y0);
    x1 = y1 = std::max(x1, y1);
  }
  if (bars) {
    x0 = -0.5;
    x1 = static_cast<double>(std::max<std::size_t>(c.categories.size(), 1)) - 0.5;
  } else {
    pad_range(x0, x1, xlog, false);
  }
  const double y_data_min = y0;
  pad_range(y0, y1, ylog, bars && !ylog);
  // Bars on a log axis start at a power of ten, so their heights compare as decades.
  if (bars && ylog && y_data_min > 0) y0 = std::min(y0, std::pow(10.0, std::floor(std::log10(y_data_min))));
  if (c.diagonal) {
    x0 = y0 = std::min(x0, y0);
    x1 = y1 = std::max(x1, y1);
  }
  Frame f{x0, x1, y0, y1, xlog, ylog};
  // Legend below the axis title: three entries a row, two where the names are long.
  std::size_t longest = 0;
  for (const auto& s : c.series) longest = std::max(longest, s.name.size());
  const std::size_t per_row = longest > 24 ? 2 : 3;
  const int legend_rows = static_cast<int>((c.series.size() + per_row - 1) / per_row);
  // Category labels are turned by 30 degrees: room for the longest (about 6.5 px a character).
  std::size_t longest_category = 0;
  for (const auto& cat : c.categories) longest_category = std::max(longest_category, cat.size());
  const double bar_label_room = bars ? 8 + 0.5 * 6.5 * static_cast<double>(longest_category) : 0;
  const double total_h = f.top + f.height + 58 + bar_label_room + 20.0 * legend_rows + 8;
  const double total_w = f.left + f.width + 24;
  std::string o = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"chart\" data-chart=\"{}\" viewBox=\"0 0 {} {}\" width=\"{}\" "
      "height=\"{}\" role=\"img\" aria-label=\"{}\">\n",
      esc(c.id), total_w, total_h, total_w, total_h, esc(c.title));
  // A title wider than the chart (about 8.6 px a character at 15 px bold) is squeezed to fit, not cut.
  const double title_room = total_w - 16;
  const std::string fit = 8.6 * static_cast<double>(c.title.size()) > title_room
                              ? fmt::format(" textLength=\"{}\" lengthAdjust=\"spacingAndGlyphs\"", title_room)
                              : std::string();
  o += fmt::format("<text class=\"title\" x=\"{}\" y=\"24\" text-anchor=\"middle\"{}>{}</text>\n",
                   fit.empty() ? f.left + f.width / 2 : total_w / 2, fit, esc(c.title));
  o += fmt::format("<rect class=\"plot\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/>\n", f.left, f.top, f.width, f.height);
  // Grid and ticks.
  for (double t : ticks(y0, y1, ylog)) {
    if (t < y0 || t > y1) continue;
    const double y = f.py(t);
    o += fmt::format("<line class=\"grid\" x1=\"{}\" y1=\"{:.2f}\" x2=\"{}\" y2=\"{:.2f}\"/>", f.left, y, f.left + f.width, y);
    o += fmt::format("<text class=\"tick\" x=\"{}\" y=\"{:.2f}\" text-anchor=\"end\">{}</text>\n", f.left - 6, y + 4,
                     esc(tick_label(t)));
  }
  if (bars) {
    for (std::size_t i = 0; i < c.categories.size(); ++i) {
      const double x = f.px(static_cast<double>(i));
      o += fmt::format(
          "<text class=\"tick\" transform=\"translate({:.2f},{}) rotate(-30)\" text-anchor=\"end\">{}</text>\n", x + 4,
          f.top + f.height + 14, esc(c.categories[i]));
    }
  } else {
    for (double t : ticks(x0, x1, xlog)) {
      if (t < x0 || t > x1) continue;
      const double x = f.px(t);
      o += fmt::format("<line class=\"grid\" x1=\"{:.2f}\" y1=\"{}\" x2=\"{:.2f}\" y2=\"{}\"/>", x, f.top, x, f.top + f.height);
      o += fmt::format("<text class=\"tick\" x=\"{:.2f}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", x,
                       f.top + f.height + 16, esc(tick_label(t)));
    }
  }
  o += fmt::format("<text class=\"axis\" x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", f.left + f.width / 2,
                   f.top + f.height + 38 + bar_label_room, esc(c.x.label + (xlog ? " (log scale)" : "")));
  o += fmt::format(
      "<text class=\"axis\" transform=\"translate(18,{}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
      f.top + f.height / 2, esc(c.y.label + (ylog ? " (log scale)" : "")));
  o += fmt::format("<svg x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" viewBox=\"{} {} {} {}\" overflow=\"hidden\">\n", f.left,
                   f.top, f.width, f.height, f.left, f.top, f.width, f.height);
  if (c.diagonal)
    o += fmt::format("<line class=\"diagonal\" x1=\"{:.2f}\" y1=\"{:.2f}\" x2=\"{:.2f}\" y2=\"{:.2f}\"/>\n", f.px(x0),
                     f.py(x0), f.px(x1), f.py(x1));
  // Bars: the bar series share each category's width.
  int n_bar_series = 0;
  for (const auto& s : c.series) n_bar_series += s.kind == SeriesKind::bars;
  int bar_index = 0;
  for (std::size_t si = 0; si < c.series.size(); ++si) {
    const Series& s = c.series[si];
    const std::string col = colour(s.colour);
    auto hover = [&](const Point& p) {
      return esc(fmt::format("{}{}{}: x {}, y {}", s.name, p.label.empty() ? "" : ", ", p.label, tick_label(p.x),
                             tick_label(p.y)));
    };
    if (s.kind == SeriesKind::line) {
      std::string pts;
      int n = 0;
      for (const auto& p : s.points) {
        if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
        pts += fmt::format("{}{:.2f},{:.2f}", n ? " " : "", f.px(p.x), f.py(p.y));
        ++n;
      }
      o += fmt::format(
          "<polyline class=\"line\" data-series=\"{}\" data-n=\"{}\" points=\"{}\" fill=\"none\" stroke=\"{}\" "
          "stroke-width=\"2\"{}/>\n",
          si, n, pts, col, s.dashed ? " stroke-dasharray=\"6 4\"" : "");
    } else if (s.kind == SeriesKind::bars) {
      const double slot = 0.8 / n_bar_series;
      const double w = std::abs(f.px(slot) - f.px(0));
      for (const auto& p : s.points) {
        const double cx = f.px(p.x - 0.4 + slot * (bar_index + 0.5));
        const double base = ylog ? f.py(y0) : f.py(std::max(0.0, y0));
        const double top = f.py(p.y);
        o += fmt::format(
            "<rect class=\"mark\" data-series=\"{}\" data-x=\"{}\" data-y=\"{}\" x=\"{:.2f}\" y=\"{:.2f}\" width=\"{:.2f}\" "
            "height=\"{:.2f}\" fill=\"{}\"><title>{}</title></rect>\n",
            si, num(p.x), num(p.y), cx - w / 2, std::min(top, base), w, std::abs(base - top), col, hover(p));
      }
      ++bar_index;
    } else {
      for (const auto& p : s.points) {
        if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
        o += fmt::format(
            "<circle class=\"mark\" data-series=\"{}\" data-x=\"{}\" data-y=\"{}\" cx=\"{:.2f}\" cy=\"{:.2f}\" r=\"{}\" "
            "fill=\"{}\" stroke=\"{}\" stroke-width=\"{}\"><title>{}</title></circle>\n",
            si, num(p.x), num(p.y), f.px(p.x), f.py(p.y), s.hollow ? 5 : 3.5, s.hollow ? "none" : col, col,
            s.hollow ? 2 : 0.5, hover(p));
      }
    }
  }
  o += "</svg>\n";
  // Legend.
  const double ly0 = f.top + f.height + 56 + bar_label_room;
  for (std::size_t i = 0; i < c.series.size(); ++i) {
    const Series& s = c.series[i];
    const double lx = f.left + static_cast<double>(i % per_row) * (f.width / static_cast<double>(per_row));
    const double ly = ly0 + 20.0 * static_cast<double>(i / per_row);
    const std::string col = colour(s.colour);
    if (s.kind == SeriesKind::line)
      o += fmt::format("<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"2\"{}/>", lx, ly - 4,
                       lx + 18, ly - 4, col, s.dashed ? " stroke-dasharray=\"6 4\"" : "");
    else if (s.kind == SeriesKind::bars)
      o += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"14\" height=\"10\" fill=\"{}\"/>", lx + 2, ly - 9, col);
    else
      o += fmt::format("<circle cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"{}\" stroke=\"{}\" stroke-width=\"{}\"/>", lx + 9, ly - 4,
                       s.hollow ? 5 : 3.5, s.hollow ? "none" : col, col, s.hollow ? 2 : 0.5);
    o += fmt::format("<text class=\"legend\" x=\"{}\" y=\"{}\">{}</text>\n", lx + 24, ly, esc(s.name));
  }
  o += "</svg>\n";
  return o;
}

std::vector<const Chart*> charts(const Document& doc) {
  std::vector<const Chart*> out;
  for (const auto& sec : doc.sections)
    for (const auto& b : sec.blocks)
      if (const auto* c = std::get_if<Chart>(&b)) out.push_back(c);
  return out;
}

std::string csv_name(const Chart& chart, int index) { return fmt::format("{:02d}-{}.csv", index, chart.id); }

std::string render_csv(const Chart& c) {
  std::string o = "series,kind,x,y,label\n";
  for (const auto& s : c.series) {
    const char* kind = s.kind == SeriesKind::line ? "line" : s.kind == SeriesKind::bars ? "bars" : "points";
    for (const auto& p : s.points) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
      o += fmt::format("{},{},{},{},{}\n", csv_field(s.name), kind, num(p.x), num(p.y), csv_field(p.label));
    }
  }
  return o;
}

namespace {

std::string table_html(const Table& t) {
  std::string o = "<table>\n<thead><tr>";
  auto cls = [&](std::size_t i) {
    const char a = i < t.align.size() ? t.align[i] : (i == 0 ? 'l' : 'r');
    return a == 'r' ? " class=\"num\"" : "";
  };
  for (std::size_t i = 0; i < t.header.size(); ++i) o += fmt::format("<th{}>{}</th>", cls(i), esc(t.header[i]));
  o += "</tr></thead>\n<tbody>\n";
  for (const auto& r : t.rows) {
    o += "<tr>";
    for (std::size_t i = 0; i < r.size(); ++i) o += fmt::format("<td{}>{}</td>", cls(i), esc(r[i]));
    o += "</tr>\n";
  }
  return o + "</tbody>\n</table>\n";
}

std::string table_md(const Table& t) {
  std::string o = "|";
  for (const auto& h : t.header) o.append(" ").append(md_cell(h)).append(" |");
  o += "\n|";
  for (std::size_t i = 0; i < t.header.size(); ++i) {
    const char a = i < t.align.size() ? t.align[i] : (i == 0 ? 'l' : 'r');
    o += a == 'r' ? " ---: |" : " --- |";
  }
  o += "\n";
  for (const auto& r : t.rows) {
    o += "|";
    for (const auto& cell : r) o.append(" ").append(md_cell(cell)).append(" |");
    o += "\n";
  }
  return o + "\n";
}

Table stamp_table(const Stamp& p) {
  Table t{{"", ""}, {}, "ll"};
  t.rows.push_back({"machine", p.machine});
  if (!p.data_date.empty()) t.rows.push_back({"measured", p.data_date});
  t.rows.push_back({"report made", p.made_at});
  t.rows.push_back({"dtflop version", p.version});
  t.rows.push_back({"command", p.command});
  for (const auto& in : p.inputs) t.rows.push_back({"input", in});
  return t;
}

constexpr const char* kCss = R"(body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;max-width:1000px;margin:24px auto;padding:0 16px;color:#222;line-height:1.45}
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.25em;margin-top:1.6em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}th,td{padding:3px 10px;border-bottom:1px solid #e3e3e3;text-align:left;vertical-align:top}
th{background:#f3f3f3}td.num,th.num{text-align:right;font-variant-numeric:tabular-nums}
table.prov td:first-child{color:#555;white-space:nowrap}.summary li{margin:.2em 0}
figure{margin:1em 0}figcaption{font-size:.85em;color:#555}
svg.chart{max-width:100%;height:auto;background:#fff}svg .title{font-size:15px;font-weight:bold}
svg .tick{font-size:11px;fill:#333}svg .axis{font-size:12.5px;fill:#222}svg .legend{font-size:12px;fill:#222}
svg .plot{fill:#fff;stroke:#888}svg .grid{stroke:#e6e6e6}svg .diagonal{stroke:#888;stroke-dasharray:5 4}
)";

}  // namespace

std::string render_html(const Document& doc) {
  std::string o = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  o += fmt::format("<title>{}</title>\n<style>\n{}</style>\n</head>\n<body>\n", esc(doc.title), kCss);
  o += fmt::format("<h1>{}</h1>\n", esc(doc.title));
  std::string prov = table_html(stamp_table(doc.stamp));
  prov.replace(0, 7, "<table class=\"prov\">");
  // The provenance table has no header row.
  const auto h0 = prov.find("<thead>"), h1 = prov.find("</thead>\n");
  if (h0 != std::string::npos && h1 != std::string::npos) prov.erase(h0, h1 + 9 - h0);
  o += prov;
  if (!doc.summary.empty()) {
    o += "<ul class=\"summary\">\n";
    for (const auto& s : doc.summary) o += fmt::format("<li>{}</li>\n", esc(s));
    o += "</ul>\n";
  }
  int chart_index = 0;
  for (const auto& sec : doc.sections) {
    o += fmt::format("<h2>{}</h2>\n", esc(sec.title));
    for (const auto& b : sec.blocks) {
      if (const auto* p = std::get_if<Paragraph>(&b)) {
        o += fmt::format("<p>{}</p>\n", esc(p->text));
      } else if (const auto* t = std::get_if<Table>(&b)) {
        o += table_html(*t);
      } else if (const auto* c = std::get_if<Chart>(&b)) {
        ++chart_index;
        o += "<figure>\n" + render_svg(*c);
        const std::string csv = csv_name(*c, chart_index);
        o += fmt::format("<figcaption>{}{}Data: <a href=\"{}\">{}</a></figcaption>\n</figure>\n", esc(c->note),
                         c->note.empty() ? "" : " ", esc(csv), esc(csv));
      }
    }
  }
  o += "</body>\n</html>\n";
  return o;
}

std::string render_markdown(const Document& doc) {
  std::string o = fmt::format("# {}\n\n", doc.title);
  o += table_md(stamp_table(doc.stamp));
  for (const auto& s : doc.summary) o += fmt::format("- {}\n", s);
  if (!doc.summary.empty()) o += "\n";
  int chart_index = 0;
  for (const auto& sec : doc.sections) {
    o += fmt::format("## {}\n\n", sec.title);
    for (const auto& b : sec.blocks) {
      if (const auto* p = std::get_if<Paragraph>(&b)) {
        o += p->text + "\n\n";
      } else if (const auto* t = std::get_if<Table>(&b)) {
        o += table_md(*t);
      } else if (const auto* c = std::get_if<Chart>(&b)) {
        ++chart_index;
        o += fmt::format("Chart: **{}** ({} against {}; data in `{}`){}\n\n", c->title, c->y.label, c->x.label,
                         csv_name(*c, chart_index), c->note.empty() ? "" : ". " + c->note);
      }
    }
  }
  return o;
}

fs::path write_report(const Document& doc, const fs::path& folder) {
  std::error_code ec;
  if (fs::symlink_status(folder, ec).type() != fs::file_type::not_found)
    throw InputError(fmt::format("'{}' already exists; a report is written into a new folder: name one that does not exist",
                                 folder.string()));
  const fs::path parent = folder.has_parent_path() ? folder.parent_path() : fs::path(".");
  if (!fs::is_directory(parent, ec))
    throw InputError(fmt::format("the folder '{}' that should hold the report does not exist; create it first",
                                 parent.string()));
  if (!fs::create_directory(folder, ec) || ec)
    throw InputError(fmt::format("cannot create the report folder '{}': {}; choose another", folder.string(),
                                 ec ? ec.message() : "it appeared meanwhile"));
  int i = 0;
  for (const Chart* c : charts(doc)) write_file_atomically(folder / csv_name(*c, ++i), render_csv(*c));
  write_file_atomically(folder / "report.md", render_markdown(doc));
  write_file_atomically(folder / "report.html", render_html(doc));
  return folder / "report.html";
}

}  // namespace dtflop::reports
