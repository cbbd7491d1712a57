// lib/report/html.cpp — the self-contained HTML report of `modal analyze
// --report` (modal/report.hpp; docs/design.md, "HTML reports"). The page is
// a fixed skeleton with the inlined assets (uPlot and lib/report/web's script
// and style, embedded at build time: report_assets.hpp) and the results as
// two JSON blocks that the script renders.
#include "html_page.hpp"
#include "report_assets.hpp"

#include "modal/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace modal {
namespace {

using html::Json;
using html::escape;
using html::script_safe;

// The equilibrium table and the shape bar charts show this many coordinates;
// the energy charts this many elements per mode (the rest summed as "others").
constexpr std::size_t shown_coordinates = 1000;
constexpr std::size_t shown_shape_components = 200;
constexpr std::size_t shown_elements = 12;

std::string coordinate_name(const Report& report, std::size_t i) {
  if (i < report.coordinates.size()) return report.coordinates[i];
  return "q" + std::to_string(i + 1);
}

// The largest shares of one mode (by magnitude) and the rest summed.
Json top_shares(const std::vector<double>& shares, const std::vector<std::string>& names) {
  std::vector<std::size_t> order(shares.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const std::size_t kept = std::min(shown_elements, order.size());
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(kept), order.end(),
                    [&](std::size_t a, std::size_t b) { return std::abs(shares[a]) > std::abs(shares[b]); });
  Json j = Json::array();
  double rest = 0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (k < kept) j.push_back({names[order[k]], shares[order[k]]});
    else rest += shares[order[k]];
  }
  if (order.size() > kept) j.push_back({fmt::format("{} others", order.size() - kept), rest});
  return j;
}

Json energy_json(const EnergyDistribution& e) {
  Json j;
  j["split"] = e.split == EnergyDistribution::Split::element ? "element" : "coordinate";
  Json directions = Json::array();
  for (const ParticipationDirection& d : e.directions) directions.push_back({{"name", d.name}, {"movable_mass", d.movable_mass}});
  j["directions"] = directions;
  Json modes = Json::array();
  for (const ModeEnergy& m : e.modes) {
    Json mj;
    mj["mode"] = m.mode;
    mj["kinetic"] = top_shares(m.kinetic, e.kinetic_elements);
    mj["potential"] = m.potential.empty() ? Json(nullptr) : top_shares(m.potential, e.potential_elements);
    mj["participation_factor"] = m.participation_factor;
    mj["effective_mass"] = m.effective_mass;
    mj["cumulative_fraction"] = m.cumulative_fraction;
    modes.push_back(mj);
  }
  j["modes"] = modes;
  return j;
}

// The drawing with the precision a picture needs (positions to 6 digits,
// displacements to 3), written by hand: nlohmann would write 17 digits.
std::string drawing_json(const SceneDrawing& d) {
  std::string s = fmt::format("{{\"dimensions\":{},\"plane\":[{},{}],\"total_points\":{},\"note\":{},\"points\":[",
                              d.dimensions, d.plane[0], d.plane[1], d.total_points, Json(d.note).dump());
  auto vectors = [&s](const std::vector<Vec3>& v, const char* format) {
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (i) s += ',';
      for (int k = 0; k < 3; ++k) {
        if (k) s += ',';
        const double x = v[i][k];
        s += std::isfinite(x) ? fmt::format(fmt::runtime(format), x == 0 ? 0.0 : x) : "0";
      }
    }
  };
  vectors(d.points, "{:.6g}");
  s += "],\"segments\":[";
  for (std::size_t i = 0; i < d.segments.size(); ++i) s += fmt::format("{}{},{}", i ? "," : "", d.segments[i][0], d.segments[i][1]);
  s += "],\"modes\":[";
  for (std::size_t m = 0; m < d.modes.size(); ++m) {
    s += fmt::format("{}{{\"mode\":{},\"displacement\":[", m ? "," : "", d.modes[m]);
    vectors(d.displacements[m], "{:.3g}");
    s += "]";
    if (m < d.displacements_imag.size() && !d.displacements_imag[m].empty()) {
      s += ",\"displacement_imag\":[";
      vectors(d.displacements_imag[m], "{:.3g}");
      s += "]";
    }
    s += "}";
  }
  s += "]}";
  return s;
}

Json report_data(const Report& report) {
  const AnalyzedEquilibrium& a = report.equilibria.front();
  const Equilibrium& e = a.equilibrium;
  const ModalResult& r = a.result;
  Json j;
  j["kind"] = "analyze";
  j["title"] = report.title;
  j["scene"] = report.scene_file;
  Json parameters = Json::array();
  for (const auto& [name, value] : report.parameters) parameters.push_back({name, csv_number(value)});
  j["parameters"] = parameters;
  Json q = Json::array();
  for (Eigen::Index i = 0; i < e.q.size() && static_cast<std::size_t>(i) < shown_coordinates; ++i) {
    const std::size_t k = static_cast<std::size_t>(i);
    const char* kind = k < report.kinds.size() ? to_string(report.kinds[k]) : "";
    q.push_back({coordinate_name(report, k), csv_number(e.q[i]), kind});
  }
  j["coordinates"] = q;
  j["coordinate_count"] = e.q.size();
  j["equilibrium"] = {{"potential", csv_number(e.potential)},
                      {"residual", csv_number(e.residual)},
                      {"residual_norm", csv_number(e.residual_norm)},
                      {"iterations", e.iterations}};
  j["stability"] = describe_stability(r);
  j["unstable"] = r.stability == Stability::divergence || r.stability == Stability::flutter;
  j["solver"] = r.solver;
  j["notes"] = r.notes;
  j["columns"] = {"mode",   "omega2",        "growth_rate", "omega",          "frequency_hz", "period",
                  "damping_ratio", "stability", "error_estimate", "residual_bound"};
  Json modes = Json::array();
  for (std::size_t k = 0; k < r.modes.size(); ++k) {
    const Mode& m = r.modes[k];
    modes.push_back({std::to_string(k + 1), csv_number(m.omega2), csv_number(m.growth_rate), csv_number(m.omega),
                     csv_number(m.frequency_hz), csv_number(m.period), csv_number(m.damping_ratio),
                     mode_stability(m.kind), csv_number(m.error_estimate), csv_number(m.residual_bound)});
  }
  j["modes"] = modes;
  // Without a drawing each shape is a bar chart of its coordinates: the real
  // parts, and beside them the imaginary parts of a complex shape
  // (first-order problems: the phase of each coordinate's motion).
  if (!a.drawing) {
    Json shapes = Json::array(), shapes_imag = Json::array();
    for (const Mode& m : r.modes) {
      Json values = Json::array(), imag = Json::array();
      bool complex = false;
      for (Eigen::Index i = 0; i < m.shape.size() && static_cast<std::size_t>(i) < shown_shape_components; ++i) {
        values.push_back(std::isfinite(m.shape[i].real()) ? m.shape[i].real() : 0.0);
        imag.push_back(std::isfinite(m.shape[i].imag()) ? m.shape[i].imag() : 0.0);
        complex = complex || (std::isfinite(m.shape[i].imag()) && m.shape[i].imag() != 0.0);
      }
      shapes.push_back(values);
      shapes_imag.push_back(complex ? imag : Json());
    }
    j["shapes"] = shapes;
    j["shapes_imag"] = shapes_imag;
    Json names = Json::array();
    for (std::size_t i = 0; i < std::min<std::size_t>(shown_shape_components, static_cast<std::size_t>(e.q.size())); ++i)
      names.push_back(coordinate_name(report, i));
    j["shape_coordinates"] = names;
  }
  if (a.energy) j["energy"] = energy_json(*a.energy);
  return j;
}

std::string_view asset(const unsigned char* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace

namespace html {

std::string script_safe(std::string text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    out += text[i];
    if (text[i] == '<' && i + 1 < text.size() && text[i + 1] == '/') out += '\\';
  }
  return out;
}

std::string escape(std::string_view text) {
  std::string out;
  for (char c : text) {
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

std::string page(const std::string& title, const std::string& what, const std::string& generator, const Json& data,
                 const std::string& drawing) {
  std::string page;
  page += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  page += "<meta name=\"generator\" content=\"" + escape(generator) + "\">\n";
  page += "<!-- This page inlines uPlot (https://github.com/leeoniya/uPlot), under this license:\n";
  page += asset(report_assets::uplot_license, report_assets::uplot_license_size);
  page += "-->\n";
  page += "<title>" + escape(title + " — " + what) + "</title>\n<style>\n";
  page += asset(report_assets::uplot_css, report_assets::uplot_css_size);
  page += "\n";
  page += asset(report_assets::report_css, report_assets::report_css_size);
  page += "\n</style>\n";
  // Errors of every later script, counted in the status line (the browser test reads it).
  page += "<script>window.modalErrors = [];"
          "window.addEventListener('error', function (e) { window.modalErrors.push(String(e.message)); });"
          "(function () { var original = console.error; console.error = function () {"
          " window.modalErrors.push(Array.prototype.join.call(arguments, ' ')); original.apply(console, arguments); };"
          "})();</script>\n</head>\n<body>\n";
  page += "<main id=\"report\"><h1>" + escape(title) + "</h1>\n";
  page += "<p id=\"report-status\" data-done=\"0\">The report is drawn by its script; if this line stays, the "
          "page's JavaScript did not run.</p>\n</main>\n";
  page += "<script type=\"application/json\" id=\"modal-data\">" + script_safe(data.dump()) + "</script>\n";
  page += "<script type=\"application/json\" id=\"modal-drawing\">" + script_safe(drawing) + "</script>\n<script>\n";
  page += asset(report_assets::uplot_js, report_assets::uplot_js_size);
  page += "\n</script>\n<script>\n";
  page += asset(report_assets::report_js, report_assets::report_js_size);
  page += "\n</script>\n</body>\n</html>\n";
  return page;
}

Json csv_table(std::string_view csv, std::size_t max_rows) {
  std::vector<std::vector<std::string>> records;
  std::vector<std::string> record;
  std::string field;
  bool quoted = false;
  for (std::size_t i = 0; i < csv.size(); ++i) {
    const char c = csv[i];
    if (quoted) {
      if (c == '"' && i + 1 < csv.size() && csv[i + 1] == '"') field += '"', ++i;
      else if (c == '"') quoted = false;
      else field += c;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      record.push_back(std::move(field));
      field.clear();
    } else if (c == '\n') {
      record.push_back(std::move(field));
      field.clear();
      records.push_back(std::move(record));
      record.clear();
    } else if (c != '\r') {
      field += c;
    }
  }
  if (!field.empty() || !record.empty()) {
    record.push_back(std::move(field));
    records.push_back(std::move(record));
  }
  Json j;
  j["columns"] = records.empty() ? Json::array() : Json(records.front());
  Json rows = Json::array();
  for (std::size_t r = 1; r < records.size() && r - 1 < max_rows; ++r) rows.push_back(records[r]);
  j["rows"] = rows;
  j["total_rows"] = records.empty() ? 0 : records.size() - 1;
  return j;
}

}  // namespace html

std::string analysis_html(const Report& report) {
  if (report.equilibria.empty()) throw std::invalid_argument("analysis_html: the report has no equilibrium");
  const AnalyzedEquilibrium& a = report.equilibria.front();
  const std::string title = report.title.empty() ? report.scene_file : report.title;
  return html::page(title, "modal analysis", "modal analyze --report", report_data(report),
                    a.drawing ? drawing_json(*a.drawing) : std::string("null"));
}

}  // namespace modal
