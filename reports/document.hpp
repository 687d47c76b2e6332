// A report as data: a title, where and how it was made, and sections of paragraphs, tables and
// charts. One document renders to three files that hold the same numbers:
//   report.html  one self-contained page: inline CSS and SVG charts, no script, nothing fetched;
//   report.md    a Markdown summary (the text and tables; each chart named with its CSV file);
//   NN-name.csv  one per chart, every plotted point: series,kind,x,y (and a label for bars).
// The SVG marks carry the same values (data-x, data-y), so a test can check a rendered page
// against the CSV files (tests/reports/).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace dtflop::reports {

// How a series is drawn: a line through its points (a prediction, a fitted curve), one marker
// per point (measurements), or one bar per point (categorical charts; x is the category index).
enum class SeriesKind { line, points, bars };

struct Point {
  double x = 0;
  double y = 0;
  std::string label;  // bars: the category; points: the configuration (shown on hover)
};

struct Series {
  std::string name;   // the legend's text
  SeriesKind kind = SeriesKind::points;
  int colour = 0;     // index into the report palette: a prediction and its measurements share one
  std::vector<Point> points;
  bool hollow = false;  // points drawn as rings (e.g. a reference such as a peak)
  bool dashed = false;  // lines drawn dashed (e.g. an asymptote)
};

struct Axis {
  std::string label;  // with the unit, e.g. "time per step [s]"
  bool log = false;
};

struct Chart {
  std::string id;     // file-name part of its CSV, e.g. "transfers-h2d"
  std::string title;
  Axis x, y;
  std::vector<Series> series;
  std::vector<std::string> categories;  // bar charts: the x tick labels, in order
  bool diagonal = false;                // draw y = x (predicted against measured)
  std::string note;                     // one line under the chart
};

struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::string align;  // one of 'l' or 'r' per column (default: first l, the rest r)
};

struct Paragraph {
  std::string text;
};

using Block = std::variant<Paragraph, Table, Chart>;

struct Section {
  std::string title;
  std::vector<Block> blocks;
};

// Where, when and how a report was made: every report states it at the top.
struct Stamp {
  std::string machine;  // the machine the data is from ("NVIDIA H200 on Intel Xeon ...")
  std::string data_date;  // when the data was measured
  std::string made_at;    // when the report was made (UTC)
  std::string version;    // dtflop version (git describe at build time)
  std::string command;    // the command line that made it
  std::vector<std::string> inputs;  // the files it was made from
};

struct Document {
  std::string kind;   // "machine", "predicted", "compare"
  std::string title;
  Stamp stamp;
  std::vector<std::string> summary;  // headline lines, shown first
  std::vector<Section> sections;
};

// The palette: colour i of the charts (cycled), as "#rrggbb".
std::string colour(int i);

std::string render_html(const Document& doc);
std::string render_markdown(const Document& doc);
// The CSV of one chart: header "series,kind,x,y,label", one row per point.
std::string render_csv(const Chart& chart);
// The file name of chart `index` (1-based) in the report: "03-transfers-h2d.csv".
std::string csv_name(const Chart& chart, int index);
// Every chart of the document, in order.
std::vector<const Chart*> charts(const Document& doc);

// Writes report.html, report.md and the CSV files into `folder`, which must not exist (its
// parent must): nothing is ever overwritten. Throws InputError (one line, what to do) when the
// folder exists or cannot be made. Returns the path of report.html.
std::filesystem::path write_report(const Document& doc, const std::filesystem::path& folder);

// The SVG of one chart (inside the HTML; exposed for tests).
std::string render_svg(const Chart& chart);

// Tick positions for an axis over [lo, hi]: 1-2-5 steps (linear) or powers of ten (log; with 2
// and 5 between when fewer than three decades). At least two ticks; `lo` and `hi` as given.
std::vector<double> ticks(double lo, double hi, bool log);
// A tick label: short, no trailing zeros, SI prefix for large and small magnitudes ("2 k",
// "500 u", "0.25").
std::string tick_label(double v);

}  // namespace dtflop::reports
