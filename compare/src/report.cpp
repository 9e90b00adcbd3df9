#include "voxpack/compare/report.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <random>
#include <sstream>

#include "figure_script.hpp"
#include "voxpack/core/atomic_file.hpp"
#include "voxpack/core/errors.hpp"
#include "voxpack/core/json_util.hpp"
#include "voxpack/core/version.hpp"

namespace voxpack::compare {
namespace fs = std::filesystem;

namespace {

constexpr const char* kFigureNames[] = {"fig_axial.png", "fig_radial.png", "fig_shadow.png",
                                        "fig_slice.png", "fig_s2.png",     "fig_mes.png"};
constexpr const char* kFigureCaptions[] = {
    ("Axial packing density along the column and the distribution of slice densities with "
     "a normal fit (paper Fig. 4)."),
    "Radial packing density against distance from the column wall (paper Fig. 6).",
    "Shadow images: mean solid fraction along y (paper Fig. 7).",
    "A horizontal slice of the void structure at mid-height, white = void (paper Fig. 8).",
    "Void two-point probability S2 against lag (paper Fig. 9).",
    "Distribution of the mean empty space (paper Fig. 10)."};
// Drawn only with compare --flow (flow.csv present).
constexpr const char* kFlowFigure = "fig_flow.png";
constexpr const char* kFlowCaption =
    "Radial profile of the axial velocity (superficial, solid counted as zero) over the mean "
    "superficial velocity against distance from the wall: wall channelling (compare --flow).";

std::string fmt(double v, int digits = 9) {
  if (!std::isfinite(v)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char ch : s) q += (ch == '"') ? std::string("\"\"") : std::string(1, ch);
  return q + "\"";
}

std::string htmlEscape(const std::string& s) {
  std::string o;
  for (char ch : s) {
    switch (ch) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      default:
        o += ch;
    }
  }
  return o;
}

std::vector<double> numbers(const nlohmann::json& obj, const char* key) {
  std::vector<double> v;
  if (!obj.is_object() || !obj.contains(key) || !obj[key].is_array()) return v;
  for (const auto& e : obj[key]) v.push_back(e.is_number() ? e.get<double>() : std::nan(""));
  return v;
}

const nlohmann::json& block(const nlohmann::json& s, const char* key) {
  static const nlohmann::json empty = nlohmann::json::object();
  return (s.is_object() && s.contains(key) && s[key].is_object()) ? s[key] : empty;
}

std::vector<const BedEntry*> entries(const Comparison& c) {
  std::vector<const BedEntry*> v{&c.reference};
  for (const auto& e : c.candidates) v.push_back(&e);
  return v;
}

std::string imageText(const Image2D& img) {
  std::ostringstream o;
  o << "# rows=" << img.rows << " cols=" << img.cols << " row_from_mm=" << fmt(img.rowFromMm)
    << " row_to_mm=" << fmt(img.rowToMm) << " col_from_mm=" << fmt(img.colFromMm)
    << " col_to_mm=" << fmt(img.colToMm) << " row_axis=" << img.rowAxis
    << " col_axis=" << img.colAxis << '\n';
  for (std::int64_t r = 0; r < img.rows; ++r) {
    for (std::int64_t col = 0; col < img.cols; ++col) {
      if (col) o << ' ';
      o << fmt(img.values[static_cast<std::size_t>(r * img.cols + col)], 4);
    }
    o << '\n';
  }
  return o.str();
}

// Axial slices used for mean/std (and the KS test) are flagged so that the histogram of
// the figure shows the same sample.
std::string axialCsv(const Comparison& c) {
  std::ostringstream o;
  o << "bed,z_mm,density,used\n";
  for (const auto* e : entries(c)) {
    const auto& a = block(e->stats, "axial");
    const auto zUsed = numbers(a, "z_mm");
    auto z = numbers(a, "z_all_mm");
    auto d = numbers(a, "density_all");
    if (z.empty() || z.size() != d.size()) {
      z = zUsed;
      d = numbers(a, "density");
    }
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double v : zUsed)
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    const double eps = 1e-9 * (1.0 + std::abs(hi));
    for (std::size_t k = 0; k < std::min(z.size(), d.size()); ++k)
      o << csvField(e->name) << ',' << fmt(z[k]) << ',' << fmt(d[k]) << ','
        << ((z[k] >= lo - eps && z[k] <= hi + eps) ? 1 : 0) << '\n';
  }
  return o.str();
}

std::string radialCsv(const Comparison& c) {
  std::ostringstream o;
  o << "bed,wall_distance_mm,r_mm,density\n";
  for (const auto* e : entries(c)) {
    const auto& r = block(e->stats, "radial");
    const auto rr = numbers(r, "r_mm");
    const auto d = numbers(r, "density");
    const auto w = wallDistanceMm(r);
    for (std::size_t k = 0; k < std::min({rr.size(), d.size(), w.size()}); ++k)
      o << csvField(e->name) << ',' << fmt(w[k]) << ',' << fmt(rr[k]) << ',' << fmt(d[k]) << '\n';
  }
  return o.str();
}

std::string pairCsv(const Comparison& c, const char* blk, const char* xKey, const char* yKey,
                    const char* xHead, const char* yHead) {
  std::ostringstream o;
  o << "bed," << xHead << ',' << yHead << '\n';
  for (const auto* e : entries(c)) {
    const auto& b = block(e->stats, blk);
    const auto x = numbers(b, xKey);
    const auto y = numbers(b, yKey);
    for (std::size_t k = 0; k < std::min(x.size(), y.size()); ++k)
      o << csvField(e->name) << ',' << fmt(x[k]) << ',' << fmt(y[k]) << '\n';
  }
  return o.str();
}

std::string bedsCsv(const Comparison& c) {
  std::ostringstream o;
  o << "index,name,role,kind,detail,synthetic,path,spacing_z_mm,spacing_y_mm,spacing_x_mm,"
       "shadow_file,slice_file\n";
  int n = 0;
  for (const auto* e : entries(c)) {
    o << n << ',' << csvField(e->name) << ',' << (n == 0 ? "reference" : "candidate") << ','
      << csvField(e->origin.kind) << ',' << csvField(e->origin.detail) << ','
      << (e->origin.synthetic ? 1 : 0) << ',' << csvField(e->path.string()) << ','
      << fmt(e->spacingMm[0]) << ',' << fmt(e->spacingMm[1]) << ',' << fmt(e->spacingMm[2])
      << ",shadow_" << n << ".txt,slice_" << n << ".txt\n";
    ++n;
  }
  return o.str();
}

std::string tableCsv(const Comparison& c) {
  std::ostringstream o;
  o << "name,role,origin,synthetic,density_mean,density_std,density_rel_diff,axial_ks_p,"
       "radial_rmse,s2_rmse,mes_ks\n";
  const auto& ra = block(c.reference.stats, "axial");
  double refMean =
      ra.contains("mean") && ra["mean"].is_number() ? ra["mean"].get<double>() : std::nan("");
  if (!std::isfinite(refMean) && c.reference.stats.contains("packing_density") &&
      c.reference.stats["packing_density"].is_number())
    refMean = c.reference.stats["packing_density"].get<double>();
  const double refStd =
      ra.contains("std") && ra["std"].is_number() ? ra["std"].get<double>() : std::nan("");
  o << csvField(c.reference.name) << ",reference," << csvField(c.reference.origin.kind) << ','
    << (c.reference.origin.synthetic ? 1 : 0) << ',' << fmt(refMean) << ',' << fmt(refStd)
    << ",0,1,0,0,0\n";
  for (std::size_t n = 0; n < c.candidates.size(); ++n) {
    const auto& e = c.candidates[n];
    const auto& d = c.distances[n];
    o << csvField(e.name) << ",candidate," << csvField(e.origin.kind) << ','
      << (e.origin.synthetic ? 1 : 0) << ',' << fmt(d.densityMean) << ',' << fmt(d.densityStd)
      << ',' << fmt(d.densityRelDiff) << ',' << fmt(d.axialKs.pValue) << ',' << fmt(d.radial.rmse)
      << ',' << fmt(d.s2.rmse) << ',' << fmt(d.mesKs) << '\n';
  }
  return o.str();
}

std::string readFile(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string shellQuote(const std::string& s) {
  std::string q = "'";
  for (char ch : s) q += (ch == '\'') ? std::string("'\\''") : std::string(1, ch);
  return q + "'";
}

std::string lastLine(const std::string& text) {
  std::string t = text;
  while (!t.empty() && (t.back() == '\n' || t.back() == '\r')) t.pop_back();
  const auto p = t.rfind('\n');
  return p == std::string::npos ? t : t.substr(p + 1);
}

// Runs the figure script into a private staging folder inside `dir` and moves the PNG
// files in one by one (rename is atomic); the staging folder is always removed.
std::vector<fs::path> drawFigures(const fs::path& dir, const ReportOptions& options,
                                  std::vector<std::string>& warnings, bool flow) {
  std::vector<fs::path> made;
  std::error_code ec;
  if (!fs::exists(options.python, ec)) {
    warnings.push_back("python interpreter " + options.python +
                       " not found: figures skipped (numbers and CSV files are complete)");
    return made;
  }
  std::random_device rd;
  const fs::path stage =
      dir / (".figures-" + std::to_string(getpid()) + "-" + std::to_string(rd() % 1000000));
  fs::create_directories(stage / "mpl", ec);
  if (ec) throw IoError("cannot create " + stage.string() + ": " + ec.message());
  struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code e;
      fs::remove_all(p, e);
    }
  } cleanup{stage};
  fs::path script = options.figureScript;
  if (script.empty()) {
    script = stage / "make_figures.py";
    std::ofstream(script) << builtinFigureScript();
  }
  const fs::path log = stage / "log.txt";
  const std::string cmd = "MPLBACKEND=Agg MPLCONFIGDIR=" + shellQuote((stage / "mpl").string()) +
                          " " + shellQuote(options.python) + " " + shellQuote(script.string()) +
                          " " + shellQuote(dir.string()) + " " + shellQuote(stage.string()) + " >" +
                          shellQuote(log.string()) + " 2>&1 </dev/null";
  const int status = std::system(cmd.c_str());
  const int code = (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
  if (code != 0) {
    const std::string why = lastLine(readFile(log));
    warnings.push_back(std::string(code == 3 ? "matplotlib/numpy not available to "
                                             : "figure script failed under ") +
                       options.python + (why.empty() ? "" : " (" + why + ")") +
                       ": figures skipped (numbers and CSV files are complete)");
    return made;
  }
  std::vector<const char*> names(std::begin(kFigureNames), std::end(kFigureNames));
  if (flow) names.push_back(kFlowFigure);
  for (const char* name : names) {
    const fs::path src = stage / name;
    if (!fs::exists(src, ec)) {
      warnings.push_back(std::string("figure ") + name + " was not drawn");
      continue;
    }
    fs::rename(src, dir / name, ec);
    if (ec) throw IoError("cannot write " + (dir / name).string() + ": " + ec.message());
    made.push_back(dir / name);
  }
  return made;
}

std::string cell(double v, int digits = 3) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream o;
  o << std::fixed << std::setprecision(digits) << v;
  return o.str();
}

std::string originText(const BedEntry& e) { return e.origin.kind + ", " + e.origin.detail; }

std::string htmlReport(const Comparison& c, const fs::path& dir,
                       const std::vector<fs::path>& figures,
                       const std::vector<std::string>& warnings) {
  std::ostringstream h;
  const std::string title = "voxpack compare: reference " + c.reference.name;
  h << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
    << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
    << "<link rel=\"icon\" href=\"data:,\">\n<title>" << htmlEscape(title) << "</title>\n"
    << "<style>\n"
       "body{font-family:sans-serif;max-width:1100px;margin:1.5em auto;padding:0 1em;color:#222}\n"
       "table{border-collapse:collapse;margin:1em 0;font-size:.88em}\n"
       "th{white-space:normal}\ntd.l{min-width:9em}\n"
       "td,th{border:1px solid #bbb;padding:.3em .6em;text-align:right}\ntd{white-space:nowrap}\n"
       "td:first-child,th:first-child,td.l{text-align:left}\ntd.l{white-space:normal}\n"
       "th{background:#eef}\n"
       ".badge{display:inline-block;font-size:.75em;padding:.1em .45em;border-radius:.6em;"
       "background:#f5d67b;color:#533;margin-left:.4em}\n"
       ".ref{background:#f6f6f6;font-weight:bold}\n"
       "figure{margin:1.5em 0}\nfigure img{max-width:100%;border:1px solid #ddd}\n"
       "figcaption{color:#555;font-size:.9em}\n.warn{color:#a40}\n"
       "</style>\n</head>\n<body>\n";
  h << "<h1>" << htmlEscape(title) << "</h1>\n";
  h << "<p>voxpack " << versionString() << ". Reference bed: <b>" << htmlEscape(c.reference.name)
    << "</b> (" << htmlEscape(originText(c.reference)) << ")";
  if (c.reference.origin.synthetic)
    h << "<span class=\"badge\">synthetic reference</span> &mdash; this reference was not imaged "
         "from a real sample (its provenance shows a voxpack phantom or simulation)";
  h << ".</p>\n";

  h << "<h2>Statistics and distances (cf. paper Table 1)</h2>\n<table id=\"summary\">\n"
    << "<tr><th>bed</th><th>origin</th><th>voxel (mm)</th><th>density mean</th>"
       "<th>density std</th><th>rel. diff.</th><th>axial KS p</th><th>radial RMSE</th>"
       "<th>S2 RMSE</th><th>MES KS</th></tr>\n";
  auto originCell = [](const BedEntry& e) {
    std::string s = htmlEscape(e.origin.kind);
    if (e.origin.synthetic && e.origin.kind != "simulated")
      s += "<span class=\"badge\">synthetic</span>";
    return s;
  };
  {
    const auto& ra = block(c.reference.stats, "axial");
    const double m =
        ra.contains("mean") && ra["mean"].is_number() ? ra["mean"].get<double>() : std::nan("");
    const double s =
        ra.contains("std") && ra["std"].is_number() ? ra["std"].get<double>() : std::nan("");
    h << "<tr class=\"ref\"><td>" << htmlEscape(c.reference.name)
      << " (reference)</td><td class=\"l\">" << originCell(c.reference) << "</td><td>"
      << cell(c.reference.spacingMm[2], 4) << "</td><td>" << cell(m) << "</td><td>" << cell(s)
      << "</td><td>&mdash;</td><td>&mdash;</td><td>&mdash;</td><td>&mdash;</td><td>&mdash;</td>"
         "</tr>\n";
    const nlohmann::json band = calibrationBand(c.reference.calibration, m);
    if (band.is_object())
      h << "<tr class=\"ref\"><td>" << htmlEscape(c.reference.name)
        << " (calibrated)</td><td class=\"l\">ingest calibration, "
        << htmlEscape(band.value("n", nlohmann::json(0)).dump()) << " phantoms</td><td></td><td>"
        << cell(band["density_band"][0].get<double>()) << " &ndash; "
        << cell(band["density_band"][1].get<double>())
        << "</td><td></td><td colspan=\"5\" class=\"l\">true density band: mean minus the "
           "expected segmentation bias "
        << cell(band["density_bias"].get<double>()) << ", &plusmn; one std</td></tr>\n";
  }
  for (std::size_t n = 0; n < c.candidates.size(); ++n) {
    const auto& e = c.candidates[n];
    const auto& d = c.distances[n];
    h << "<tr><td>" << htmlEscape(e.name) << "</td><td class=\"l\">" << originCell(e) << " "
      << htmlEscape(e.origin.detail) << "</td><td>" << cell(e.spacingMm[2], 4) << "</td><td>"
      << cell(d.densityMean) << "</td><td>" << cell(d.densityStd) << "</td><td>"
      << (std::isfinite(d.densityRelDiff) ? cell(100.0 * d.densityRelDiff, 1) + " %" : "n/a")
      << "</td><td>" << cell(d.axialKs.pValue, 3) << "</td><td>" << cell(d.radial.rmse, 4)
      << "</td><td>" << cell(d.s2.rmse, 4) << "</td><td>" << cell(d.mesKs, 3) << "</td></tr>\n";
  }
  h << "</table>\n";
  h << "<p>Density: mean and standard deviation of the slice packing densities away from the "
       "bed ends; rel. diff. = (candidate &minus; reference) / reference. Axial KS p: two-sample "
       "Kolmogorov&ndash;Smirnov test of the slice densities (slices along z are correlated, so "
       "read it as a similarity score, not a calibrated test). Radial RMSE: packing density vs "
       "distance from the wall, both interpolated linearly onto a common grid in mm over the "
       "overlapping range. S2 RMSE: the same for S2(h) on a common lag grid. MES KS: largest "
       "difference between the cumulative mean-empty-space distributions. Beds of different "
       "voxel sizes are compared in mm.</p>\n";

  h << "<h2>Beds</h2>\n<table id=\"beds\">\n<tr><th>bed</th><th>role</th><th>origin</th>"
       "<th>file</th><th>voxel z,y,x (mm)</th><th>packed region z "
       "(mm)</th><th>porosity</th></tr>\n";
  int n = 0;
  for (const auto* e : entries(c)) {
    const double por = e->stats.contains("porosity") && e->stats["porosity"].is_number()
                           ? e->stats["porosity"].get<double>()
                           : std::nan("");
    h << "<tr><td>" << htmlEscape(e->name) << "</td><td class=\"l\">"
      << (n == 0 ? "reference" : "candidate") << "</td><td class=\"l\">" << originCell(*e) << " "
      << htmlEscape(e->origin.detail) << "</td><td class=\"l\">" << htmlEscape(e->path.string())
      << "</td><td>" << cell(e->spacingMm[0], 4) << ", " << cell(e->spacingMm[1], 4) << ", "
      << cell(e->spacingMm[2], 4) << "</td><td>" << cell(e->region.fromMm, 2) << " &ndash; "
      << cell(e->region.toMm, 2) << "</td><td>" << cell(por, 4) << "</td></tr>\n";
    ++n;
  }
  h << "</table>\n";
  h << flowHtmlTable(c);

  if (!warnings.empty()) {
    h << "<h2>Warnings</h2>\n<ul class=\"warn\">\n";
    for (const auto& w : warnings) h << "<li>" << htmlEscape(w) << "</li>\n";
    h << "</ul>\n";
  }

  h << "<h2>Figures</h2>\n";
  if (figures.empty())
    h << "<p class=\"warn\">No figures: matplotlib was not available when this report was "
         "made. The data behind every figure is in the CSV files beside this page.</p>\n";
  for (std::size_t k = 0; k < std::size(kFigureNames); ++k) {
    const fs::path p = dir / kFigureNames[k];
    bool have = false;
    for (const auto& f : figures) have = have || f == p;
    if (!have) continue;
    h << "<figure><img id=\"" << fs::path(kFigureNames[k]).stem().string() << "\" alt=\""
      << htmlEscape(kFigureCaptions[k]) << "\" src=\"data:image/png;base64," << base64(readFile(p))
      << "\">\n<figcaption>" << htmlEscape(kFigureCaptions[k]) << "</figcaption></figure>\n";
  }
  for (const auto& f : figures)
    if (f.filename() == kFlowFigure)
      h << "<figure><img id=\"fig_flow\" alt=\"" << htmlEscape(kFlowCaption)
        << "\" src=\"data:image/png;base64," << base64(readFile(f)) << "\">\n<figcaption>"
        << htmlEscape(kFlowCaption) << "</figcaption></figure>\n";
  h << "<p>Data files: summary.json, table.csv, beds.csv, axial.csv, radial.csv, s2.csv, "
       "mes.csv, shadow_N.txt, slice_N.txt.</p>\n";
  // Records each figure's decoded size on the page, so a headless browser check can read
  // it back from the DOM.
  h << "<script>\nwindow.addEventListener('load', function () {\n"
       "  var out = [];\n"
       "  for (var i = 0; i < document.images.length; i++) {\n"
       "    var im = document.images[i];\n"
       "    out.push(im.id + '=' + im.naturalWidth + 'x' + im.naturalHeight);\n"
       "  }\n"
       "  document.body.setAttribute('data-image-sizes', out.join(' '));\n"
       "});\n</script>\n";
  h << "</body>\n</html>\n";
  return h.str();
}

}  // namespace

const char* builtinFigureScript() { return detail::kFigureScript; }

std::string base64(const std::string& bytes) {
  static const char* tbl = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(bytes[i]) << 16) |
                       (static_cast<unsigned char>(bytes[i + 1]) << 8) |
                       static_cast<unsigned char>(bytes[i + 2]);
    out += tbl[(v >> 18) & 63];
    out += tbl[(v >> 12) & 63];
    out += tbl[(v >> 6) & 63];
    out += tbl[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    out += tbl[(v >> 18) & 63];
    out += tbl[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const unsigned v = (static_cast<unsigned char>(bytes[i]) << 16) |
                       (static_cast<unsigned char>(bytes[i + 1]) << 8);
    out += tbl[(v >> 18) & 63];
    out += tbl[(v >> 12) & 63];
    out += tbl[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

nlohmann::json summaryJson(const Comparison& c, const nlohmann::json& extras) {
  nlohmann::json j = nlohmann::json::object();
  if (extras.is_object())
    for (const auto& [k, v] : extras.items()) j[k] = v;
  j["reference"] = c.reference.name;
  j["candidates"] = nlohmann::json::array();
  for (std::size_t n = 0; n < c.candidates.size(); ++n)
    j["candidates"].push_back(distancesToJson(c.candidates[n].name, c.distances[n]));
  j["beds"] = nlohmann::json::array();
  int n = 0;
  for (const auto* e : entries(c)) {
    j["beds"].push_back({{"name", e->name},
                         {"role", n == 0 ? "reference" : "candidate"},
                         {"path", e->path.string()},
                         {"origin", e->origin.kind},
                         {"origin_detail", e->origin.detail},
                         {"synthetic", e->origin.synthetic},
                         {"spacing_mm", e->spacingMm},
                         {"packed_region_mm", {e->region.fromMm, e->region.toMm}},
                         {"packed_region_cropped", e->region.cropped}});
    ++n;
  }
  j["reference_stats"] = c.reference.stats;
  {
    const auto& ra =
        c.reference.stats.contains("axial") ? c.reference.stats["axial"] : nlohmann::json();
    const double m = ra.is_object() && ra.contains("mean") && ra["mean"].is_number()
                         ? ra["mean"].get<double>()
                         : std::nan("");
    j["reference_calibration"] = calibrationBand(c.reference.calibration, m);
  }
  j["candidate_stats"] = nlohmann::json::object();
  for (const auto& e : c.candidates) j["candidate_stats"][e.name] = e.stats;
  if (hasFlow(c)) j["flow"] = flowSummary(c);
  j["warnings"] = c.warnings;
  sanitizeNonFinite(j);
  return j;
}

std::string formatTable(const Comparison& c) {
  std::size_t w = 9;
  for (const auto* e : entries(c)) w = std::max(w, e->name.size() + 2);
  std::ostringstream o;
  auto col = [&](const std::string& s, std::size_t width) {
    o << std::setw(static_cast<int>(width)) << s;
  };
  o << std::left << std::setw(static_cast<int>(w)) << "bed" << std::right;
  for (const char* head :
       {"origin", "mean", "std", "rel.diff", "axialKSp", "radialRMSE", "S2RMSE", "MES_KS"})
    col(head, std::string(head) == "origin" ? 17 : 11);
  o << '\n';
  const auto& ra = block(c.reference.stats, "axial");
  const double m =
      ra.contains("mean") && ra["mean"].is_number() ? ra["mean"].get<double>() : std::nan("");
  const double s =
      ra.contains("std") && ra["std"].is_number() ? ra["std"].get<double>() : std::nan("");
  o << std::left << std::setw(static_cast<int>(w)) << c.reference.name << std::right;
  col(c.reference.origin.synthetic && c.reference.origin.kind != "simulated" ? "synthetic ref"
                                                                             : "reference",
      17);
  col(cell(m), 11);
  col(cell(s), 11);
  for (int k = 0; k < 5; ++k) col("-", 11);
  o << '\n';
  // The reference's ingest error budget, when it has one: the density it stands for once
  // the segmentation bias measured on its phantoms is taken off.
  const nlohmann::json band = calibrationBand(c.reference.calibration, m);
  if (band.is_object())
    o << "  calibrated: true density " << cell(band["density_band"][0].get<double>(), 4) << " - "
      << cell(band["density_band"][1].get<double>(), 4) << " (ingest bias "
      << cell(band["density_bias"].get<double>(), 4) << " on "
      << band.value("n", nlohmann::json(0)).dump() << " phantoms at its SNR and blur)\n";
  for (std::size_t n = 0; n < c.candidates.size(); ++n) {
    const auto& e = c.candidates[n];
    const auto& d = c.distances[n];
    o << std::left << std::setw(static_cast<int>(w)) << e.name << std::right;
    col(e.origin.detail.size() <= 16 ? e.origin.detail : e.origin.kind, 17);
    col(cell(d.densityMean), 11);
    col(cell(d.densityStd), 11);
    col(std::isfinite(d.densityRelDiff) ? cell(100.0 * d.densityRelDiff, 1) + "%" : "n/a", 11);
    col(cell(d.axialKs.pValue), 11);
    col(cell(d.radial.rmse, 4), 11);
    col(cell(d.s2.rmse, 4), 11);
    col(cell(d.mesKs), 11);
    o << '\n';
  }
  return o.str();
}

ReportResult writeReport(const fs::path& dir, const Comparison& c, const ReportOptions& options,
                         Progress& progress) {
  ensureWritableDirectory(dir, true);
  ReportResult r;
  r.warnings = c.warnings;
  progress.report("compare: report", 0.0);
  writeTextFileAtomic(dir / "table.csv", tableCsv(c));
  writeTextFileAtomic(dir / "beds.csv", bedsCsv(c));
  writeTextFileAtomic(dir / "axial.csv", axialCsv(c));
  writeTextFileAtomic(dir / "radial.csv", radialCsv(c));
  writeTextFileAtomic(dir / "s2.csv", pairCsv(c, "s2", "h_mm", "s2", "h_mm", "s2"));
  writeTextFileAtomic(dir / "mes.csv", pairCsv(c, "mes", "bins_mm", "pdf", "bin_mm", "pdf"));
  int n = 0;
  for (const auto* e : entries(c)) {
    writeTextFileAtomic(dir / ("shadow_" + std::to_string(n) + ".txt"), imageText(e->shadow));
    writeTextFileAtomic(dir / ("slice_" + std::to_string(n) + ".txt"), imageText(e->slice));
    ++n;
  }
  if (hasFlow(c)) writeTextFileAtomic(dir / "flow.csv", flowProfileCsv(c));
  progress.report("compare: report", 0.3);
  if (options.figures) r.figures = drawFigures(dir, options, r.warnings, hasFlow(c));
  // A figure left from an earlier run in the same folder would not match these numbers.
  std::vector<const char*> stale(std::begin(kFigureNames), std::end(kFigureNames));
  stale.push_back(kFlowFigure);
  for (const char* name : stale) {
    bool made = false;
    for (const auto& f : r.figures) made = made || f.filename() == name;
    std::error_code ec;
    if (!made) fs::remove(dir / name, ec);
  }
  progress.report("compare: report", 0.9);
  nlohmann::json extras = options.summaryExtras;
  if (!extras.is_object()) extras = nlohmann::json::object();
  nlohmann::json summary = summaryJson(c, extras);
  summary["warnings"] = r.warnings;  // the report's own warnings too (figures skipped...)
  r.summaryJson = dir / "summary.json";
  writeJsonFile(r.summaryJson, summary);
  r.indexHtml = dir / "index.html";
  writeTextFileAtomic(r.indexHtml, htmlReport(c, dir, r.figures, r.warnings));
  progress.report("compare: report", 1.0);
  return r;
}

}  // namespace voxpack::compare
