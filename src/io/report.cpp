#include "dbbkit/io/report.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>
#include <vector>

#include "dbbkit/error.hpp"
#include "dbbkit/io/json_reader.hpp"
#include "dbbkit/io/output.hpp"
#include "dbbkit/kinematics.hpp"

namespace dbbkit::io {

namespace {

constexpr std::array<std::uint32_t, 64> kSha256K = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

std::uint32_t rotr(std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

// A string for a gnuplot single-quoted literal.
std::string gq(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

std::string num(double x) {
  if (!std::isfinite(x)) return "NaN";
  std::ostringstream s;
  s << std::setprecision(10) << x;
  return s.str();
}

const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                          "#ff7f0e", "#17becf", "#8c564b", "#e377c2"};

std::string series_block(const PlotSeries& s, int index) {
  std::ostringstream b;
  b << "$d" << index << " << EOD\n";
  for (size_t i = 0; i < s.x.size(); ++i) {
    b << num(s.x[i]) << " " << num(s.y[i]);
    if (!s.lo.empty()) b << " " << num(s.lo[i]) << " " << num(s.hi[i]);
    b << "\n";
  }
  b << "EOD\n";
  return b.str();
}

std::string series_plot(const PlotSeries& s, int index) {
  const std::string colour = kColours[index % 8];
  std::ostringstream p;
  if (!s.lo.empty()) {
    p << "$d" << index << " using 1:3:4 with filledcurves fc rgb '" << colour
      << "' fs transparent solid 0.18 noborder notitle, ";
  }
  p << "$d" << index << " using 1:2 with " << s.style << " lc rgb '" << colour
    << "' lw 1.5 pt 7 ps 0.5 title " << gq(s.title);
  return p.str();
}

}  // namespace

std::string sha256_hex(const std::string& bytes) {
  std::array<std::uint32_t, 8> h = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                                    0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  std::string m = bytes;
  const std::uint64_t bits = static_cast<std::uint64_t>(bytes.size()) * 8;
  m += static_cast<char>(0x80);
  while (m.size() % 64 != 56) m += '\0';
  for (int i = 7; i >= 0; --i) m += static_cast<char>((bits >> (8 * i)) & 0xff);
  for (size_t off = 0; off < m.size(); off += 64) {
    std::array<std::uint32_t, 64> w{};
    for (int i = 0; i < 16; ++i) {
      w[i] = 0;
      for (int j = 0; j < 4; ++j)
        w[i] = (w[i] << 8) | static_cast<unsigned char>(m[off + 4 * i + j]);
    }
    for (int i = 16; i < 64; ++i) {
      const std::uint32_t s0 = rotr(w[i - 15], 7) ^ rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
      const std::uint32_t s1 = rotr(w[i - 2], 17) ^ rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
      w[i] = w[i - 16] + s0 + w[i - 7] + s1;
    }
    std::array<std::uint32_t, 8> v = h;
    for (int i = 0; i < 64; ++i) {
      const std::uint32_t S1 = rotr(v[4], 6) ^ rotr(v[4], 11) ^ rotr(v[4], 25);
      const std::uint32_t ch = (v[4] & v[5]) ^ (~v[4] & v[6]);
      const std::uint32_t t1 = v[7] + S1 + ch + kSha256K[i] + w[i];
      const std::uint32_t S0 = rotr(v[0], 2) ^ rotr(v[0], 13) ^ rotr(v[0], 22);
      const std::uint32_t maj = (v[0] & v[1]) ^ (v[0] & v[2]) ^ (v[1] & v[2]);
      const std::uint32_t t2 = S0 + maj;
      v = {t1 + t2, v[0], v[1], v[2], v[3] + t1, v[4], v[5], v[6]};
    }
    for (int i = 0; i < 8; ++i) h[i] += v[i];
  }
  std::ostringstream out;
  for (std::uint32_t x : h) out << std::hex << std::setw(8) << std::setfill('0') << x;
  return out.str();
}

std::string sha256_file(const std::string& path) { return sha256_hex(read_text_file(path)); }

std::string gnuplot_svg(const std::string& script, int width_px, int height_px) {
  // A private directory (mkdtemp, mode 0700) holds the script, the plot and gnuplot's
  // messages: nothing in a shared temporary directory is ever opened by a guessable
  // name. The directory and its files are known to the signal handlers (output.hpp).
  std::string dir = (std::filesystem::temp_directory_path() / "dbbkit-plot-XXXXXX").string();
  if (!::mkdtemp(dir.data()))
    throw InputError("--report", "", "cannot create a temporary directory for gnuplot");
  const int dir_slot = internal::register_temporary(dir, true);
  const std::string gp = dir + "/plot.gp", svg = dir + "/plot.svg", log = dir + "/plot.log";
  std::vector<int> slots;
  for (const std::string& f : {gp, svg, log}) slots.push_back(internal::register_temporary(f));
  auto cleanup = [&]() {
    for (const std::string& f : {gp, svg, log}) ::unlink(f.c_str());
    ::rmdir(dir.c_str());
    for (int s : slots) internal::unregister_temporary(s);
    internal::unregister_temporary(dir_slot);
  };
  std::string out, err;
  int status = -1;
  bool not_found = false;
  {
    std::ofstream f(gp);
    f << "set terminal svg size " << width_px << "," << height_px
      << " noenhanced font 'sans,11' background rgb 'white'\n"
      << "set output " << gq(svg) << "\nset datafile missing NaN\n"
      << script << "\nunset output\n";
  }
  // gnuplot runs as a child of this process (not through a shell), its messages to the log.
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::string arg0 = "gnuplot";
  std::string arg1 = gp;
  char* argv[] = {arg0.data(), arg1.data(), nullptr};
  pid_t pid = 0;
  const int rc = ::posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    not_found = rc == ENOENT;
  } else {
    int wstatus = 0;
    while (::waitpid(pid, &wstatus, 0) < 0 && errno == EINTR) {
    }
    status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1;
    if (status == 0 && std::filesystem::exists(svg)) out = read_text_file(svg);
    if (std::filesystem::exists(log)) err = read_text_file(log);
  }
  cleanup();
  if (out.empty()) {
    throw InputError(
        "--report", "",
        not_found
            ? "gnuplot draws the plots and was not found; install gnuplot-nox (./setup.sh does)"
            : "gnuplot failed: " + err.substr(0, 400));
  }
  // Drop the XML prolog and DOCTYPE: the SVG is inlined in HTML.
  const size_t start = out.find("<svg");
  return start == std::string::npos ? out : out.substr(start);
}

std::string plot_series(const std::string& title, const std::string& xlabel,
                        const std::string& ylabel, const std::vector<PlotSeries>& series,
                        int width_px, int height_px) {
  std::ostringstream s;
  for (size_t i = 0; i < series.size(); ++i) s << series_block(series[i], static_cast<int>(i));
  s << "set title " << gq(title) << "\nset xlabel " << gq(xlabel) << "\nset ylabel " << gq(ylabel)
    << "\nset grid\nset key outside right top\nplot ";
  for (size_t i = 0; i < series.size(); ++i)
    s << (i ? ", " : "") << series_plot(series[i], static_cast<int>(i));
  s << "\n";
  return gnuplot_svg(s.str(), width_px, height_px);
}

std::string plot_design(const Design& design) {
  std::ostringstream bars;
  bars << "$bars << EOD\n";
  std::vector<std::pair<Eigen::Vector3d, std::string>> balls;  // ball position, installation id
  for (const Installation& in : design.installations) {
    const Eigen::Vector3d P = ball_body_mm(design.axis, in);
    const double length = in.bar_mm ? *in.bar_mm : 40.0;
    const Eigen::Vector3d F = in.bar_mm ? Eigen::Vector3d(P - in.sign * length * in.direction.body)
                                        : Eigen::Vector3d(P + length * in.direction.body);
    bars << num(P.x()) << " " << num(P.y()) << " " << num(P.z()) << " " << num(F.x() - P.x()) << " "
         << num(F.y() - P.y()) << " " << num(F.z() - P.z()) << "\n";
    balls.emplace_back(P, in.id);
  }
  bars << "EOD\n";
  // The labels of each view: installations whose balls project to one point share a label
  // (e.g. two axial readings on the axis at different heights, seen from above); along the
  // view's horizontal axis, neighbouring labels alternate above and below their point, so
  // that balls close together keep readable labels.
  auto labels = [&](const std::string& name, int h, int v) {
    struct Point {
      double x, y;
      std::string ids;
    };
    std::vector<Point> points;
    for (const auto& [P, id] : balls) {
      bool found = false;
      for (Point& q : points) {
        if (std::abs(q.x - P(h)) < 1e-6 && std::abs(q.y - P(v)) < 1e-6) {
          if (("," + q.ids + ",").find("," + id + ",") == std::string::npos) q.ids += "," + id;
          found = true;
        }
      }
      if (!found) points.push_back({P(h), P(v), id});
    }
    // Along each level of the view's vertical coordinate, by the horizontal one: $<name>0
    // holds every other point from the first (labels above), $<name>1 the rest (below).
    std::stable_sort(points.begin(), points.end(), [](const Point& a, const Point& b) {
      return a.y < b.y || (a.y == b.y && a.x < b.x);
    });
    std::array<std::vector<const Point*>, 2> sets;
    for (size_t i = 0, k = 0; i < points.size(); ++i) {
      k = i > 0 && std::abs(points[i].y - points[i - 1].y) < 1e-6 ? k + 1 : 0;
      sets[k % 2].push_back(&points[i]);
    }
    std::ostringstream d, plot;
    for (size_t parity = 0; parity < 2; ++parity) {
      if (sets[parity].empty()) continue;
      d << "$" << name << parity << " << EOD\n";
      for (const Point* q : sets[parity])
        d << num(q->x) << " " << num(q->y) << " \"" << q->ids << "\"\n";
      d << "EOD\n";
      plot << ", $" << name << parity << " using 1:2 with points pt 7 ps 1.2 lc rgb '#d62728', $"
           << name << parity << " using 1:2:3 with labels offset 0," << (parity == 0 ? "1" : "-1")
           << " font 'sans,9'";
    }
    return std::make_pair(d.str(), plot.str());
  };
  const bool c = design.axis == Axis::C;
  const std::string what =
      design.installations.front().bar_mm ? "bar to the following ball" : "reading direction";
  const auto [top_data, top_plot] = labels("top", 0, 1);
  const auto [side_data, side_plot] = labels("side", 0, 2);
  std::ostringstream s;
  s << bars.str() << top_data << side_data << "set multiplot layout 1,2 title "
    << gq("design " + design.name + " (axis " + axis_name(design.axis) +
          ", body frame = machine frame at angle 0; lines: " + what + ")")
    << "\nset size ratio -1\nset grid\nset key off\nset offsets graph 0.08, graph 0.08, graph "
       "0.08, graph 0.08\n";
  // Top view x, y; side view x, z. The axis of rotation is drawn: C about z, B about y.
  s << "set title 'top view (x, y) [mm]'\nset xlabel 'x [mm]'\nset ylabel 'y [mm]'\n";
  if (!c) s << "set arrow 1 from 0,graph 0 to 0,graph 1 nohead dt 2 lc rgb '#888888'\n";
  s << "plot $bars using 1:2:4:5 with vectors nohead lw 2 lc rgb '#1f77b4'" << top_plot
    << (c ? ", '+' using (0):(0) with points pt 2 ps 2 lc rgb '#888888'" : "") << "\n";
  s << "unset arrow 1\nset title 'side view (x, z) [mm]'\nset xlabel 'x [mm]'\nset ylabel 'z "
       "[mm]'\n";
  if (c) s << "set arrow 1 from 0,graph 0 to 0,graph 1 nohead dt 2 lc rgb '#888888'\n";
  s << "plot $bars using 1:3:4:6 with vectors nohead lw 2 lc rgb '#1f77b4'" << side_plot
    << (c ? "" : ", '+' using (0):(0) with points pt 2 ps 2 lc rgb '#888888'") << "\n";
  s << "unset multiplot\n";
  return gnuplot_svg(s.str(), 900, 420);
}

std::string plot_errors(const std::vector<ErrorsAtAngle>& errors, bool values, double k,
                        const std::string& title) {
  std::vector<PlotSeries> tr, rot;
  for (int e = 0; e < 6; ++e) {
    PlotSeries s;
    s.title = kErrorNames[e];
    for (const ErrorsAtAngle& ea : errors) {
      const Determined& d = ea.errors[e];
      const double v =
          d.determined ? (values ? d.value : 0.0) : std::numeric_limits<double>::quiet_NaN();
      const double U = d.determined ? k * d.std : std::numeric_limits<double>::quiet_NaN();
      s.x.push_back(ea.angle_deg);
      s.y.push_back(values ? v : U);
      s.lo.push_back(v - U);
      s.hi.push_back(v + U);
    }
    if (!values) s.lo.clear(), s.hi.clear();
    (e < 3 ? tr : rot).push_back(s);
  }
  std::ostringstream sc;
  int index = 0;
  for (const PlotSeries& s : tr) sc << series_block(s, index++);
  for (const PlotSeries& s : rot) sc << series_block(s, index++);
  const std::string what = values ? "value with band +-U" : "U (a priori)";
  sc << "set multiplot layout 2,1 title " << gq(title) << "\nset grid\nset key outside right top\n"
     << "set xlabel 'angle [deg]'\n";
  sc << "set title " << gq("translations: " + what) << "\nset ylabel 'um'\nplot ";
  for (int i = 0; i < 3; ++i) sc << (i ? ", " : "") << series_plot(tr[i], i);
  sc << "\nset title " << gq("rotations: " + what) << "\nset ylabel 'urad'\nplot ";
  for (int i = 0; i < 3; ++i) sc << (i ? ", " : "") << series_plot(rot[i], i + 3);
  sc << "\nunset multiplot\n";
  return gnuplot_svg(sc.str(), 900, 640);
}

std::string plot_heatmap(const std::string& title, const std::string& xlabel,
                         const std::string& ylabel, const std::string& zlabel,
                         const std::vector<double>& x, const std::vector<double>& y,
                         const std::vector<double>& z) {
  std::ostringstream s;
  s << "$map << EOD\n";
  for (size_t j = 0; j < y.size(); ++j) {
    for (size_t i = 0; i < x.size(); ++i)
      s << num(x[i]) << " " << num(y[j]) << " " << num(z[j * x.size() + i]) << "\n";
    s << "\n";
  }
  s << "EOD\nset title " << gq(title) << "\nset xlabel " << gq(xlabel) << "\nset ylabel "
    << gq(ylabel) << "\nset cblabel " << gq(zlabel)
    << "\nset palette rgbformulae 33,13,10\nset tics out\n"
    << "plot $map using 1:2:3 with image notitle\n";
  return gnuplot_svg(s.str(), 760, 480);
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

HtmlReport::HtmlReport(const std::string& title) : title_(title) {}

void HtmlReport::heading(const std::string& text, int level) {
  body_ += "<h" + std::to_string(level) + ">" + html_escape(text) + "</h" + std::to_string(level) +
           ">\n";
}
void HtmlReport::paragraph(const std::string& text) {
  body_ += "<p>" + html_escape(text) + "</p>\n";
}
void HtmlReport::preformatted(const std::string& text) {
  body_ += "<pre>" + html_escape(text) + "</pre>\n";
}
void HtmlReport::table(const std::vector<std::string>& header,
                       const std::vector<std::vector<std::string>>& rows) {
  std::string t = "<table><thead><tr>";
  for (const std::string& h : header) t += "<th>" + html_escape(h) + "</th>";
  t += "</tr></thead><tbody>\n";
  for (const auto& row : rows) {
    t += "<tr>";
    for (const std::string& c : row) t += "<td>" + html_escape(c) + "</td>";
    t += "</tr>\n";
  }
  body_ += t + "</tbody></table>\n";
}
void HtmlReport::figure(const std::string& svg, const std::string& caption) {
  ++figures_;
  body_ += "<figure class=\"plot\">" + svg + "<figcaption>" + html_escape(caption) +
           "</figcaption></figure>\n";
}

namespace {
std::vector<std::vector<std::string>> condition_rows(const std::string& command,
                                                     const std::vector<std::string>& inputs,
                                                     const Design* design) {
  std::vector<std::vector<std::string>> rows = {
      {"software", std::string("dbbkit ") + DBBKIT_VERSION}, {"command", command}};
  for (const std::string& f : inputs) {
    if (!f.empty()) rows.push_back({"input " + f, "SHA-256 " + sha256_file(f)});
  }
  if (design) {
    rows.push_back({"noise", design->noise.describe()});
    rows.push_back({"error model", design->errors.describe()});
    if (design->reference_length_mm)
      rows.push_back({"reference length", fmt_num(*design->reference_length_mm) + " mm"});
    for (const auto& [k, v] : design->assumed) rows.push_back({"assumed: " + k, v});
  }
  return rows;
}
}  // namespace

void HtmlReport::conditions(const std::string& command, const std::vector<std::string>& inputs,
                            const Design* design) {
  heading("Conditions");
  table({"item", "value"}, condition_rows(command, inputs, design));
}

std::string HtmlReport::str() const {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>"
    << html_escape(title_)
    << "</title>\n<style>body{font-family:sans-serif;max-width:72em;margin:2em auto;padding:0 "
       "1em;color:#222}"
       "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:2px 8px;"
       "text-align:right;font-variant-numeric:tabular-nums}th{background:#eee}td:first-child{text-"
       "align:left}"
       "figure{margin:1em 0}figure "
       "svg{max-width:100%;height:auto}figcaption{font-size:90%;color:#555}"
       "pre{background:#f6f6f6;padding:0.5em;overflow-x:auto}</style>\n</head><body>\n<h1>"
    << html_escape(title_) << "</h1>\n"
    << body_
    // A self-check a browser runs on load: every plot present, drawn, and holding data;
    // no script error; nothing fetched from elsewhere (the file is self-contained).
    << "<p id=\"selfcheck\" data-status=\"pending\" "
       "style=\"color:#999;font-size:80%\"></p>\n<script>\n"
       "window.__errors=[];window.addEventListener('error',function(e){window.__errors.push(String("
       "e.message));});\n"
       "window.addEventListener('load',function(){var "
       "figs=document.querySelectorAll('figure.plot');var bad=[];\n"
       "for(var i=0;i<figs.length;i++){var s=figs[i].querySelector('svg');if(!s){bad.push(i+': no "
       "svg');continue;}\n"
       "var b=s.getBoundingClientRect();var data=0;var "
       "gs=s.querySelectorAll('g[id^=\"gnuplot_plot_\"]');\n"
       "for(var j=0;j<gs.length;j++){var ps=gs[j].querySelectorAll('path,image,use');"
       "for(var k=0;k<ps.length;k++){var "
       "d=ps[k].getAttribute('d');if(ps[k].tagName!=='path'||(d&&d.length>20))data++;}}\n"
       "if(b.width<100||b.height<100)bad.push(i+': not drawn');else if(data===0)bad.push(i+': no "
       "data');}\n"
       "var ext=performance.getEntriesByType('resource').length;var "
       "el=document.getElementById('selfcheck');\n"
       "el.setAttribute('data-status',(bad.length||window.__errors.length||ext)?'fail':'ok');\n"
       "el.textContent='self-check: '+figs.length+' plots, '+bad.length+' empty, "
       "'+window.__errors.length+"
       "' script errors, '+ext+' external resources'+(bad.length?' ('+bad.join('; ')+')':'');});\n"
       "</script>\n</body></html>\n";
  return h.str();
}

MarkdownSummary::MarkdownSummary(const std::string& title) : text_("# " + title + "\n\n") {}
void MarkdownSummary::heading(const std::string& text, int level) {
  text_ += std::string(static_cast<size_t>(level), '#') + " " + text + "\n\n";
}
void MarkdownSummary::paragraph(const std::string& text) { text_ += text + "\n\n"; }
void MarkdownSummary::preformatted(const std::string& text) {
  text_ += "```\n" + text + (text.empty() || text.back() == '\n' ? "" : "\n") + "```\n\n";
}
void MarkdownSummary::table(const std::vector<std::string>& header,
                            const std::vector<std::vector<std::string>>& rows) {
  auto cell = [](std::string s) {
    std::string out;
    for (char c : s) out += c == '|' ? std::string("\\|") : std::string(1, c);
    return out;
  };
  std::string t = "|";
  for (const std::string& h : header) t += " " + cell(h) + " |";
  t += "\n|";
  for (size_t i = 0; i < header.size(); ++i) t += i ? "---:|" : "---|";
  t += "\n";
  for (const auto& row : rows) {
    t += "|";
    for (const std::string& c : row) t += " " + cell(c) + " |";
    t += "\n";
  }
  text_ += t + "\n";
}
void MarkdownSummary::conditions(const std::string& command, const std::vector<std::string>& inputs,
                                 const Design* design) {
  heading("Conditions");
  table({"item", "value"}, condition_rows(command, inputs, design));
}

std::string fmt_num(double x, int digits) {
  std::ostringstream s;
  s << std::setprecision(digits) << x;
  return s.str();
}

std::string fmt_opt(const std::optional<double>& x, int digits) {
  return x ? fmt_num(*x, digits) : "--";
}

std::vector<std::string> errors_header(bool values) {
  std::vector<std::string> h = {"angle [deg]"};
  for (int e = 0; e < 6; ++e) {
    h.push_back(std::string(kErrorNames[e]) + (values ? " ± U" : " U") + " [" + kErrorUnits[e] +
                "]");
  }
  return h;
}

std::vector<std::vector<std::string>> errors_rows(const std::vector<ErrorsAtAngle>& errors,
                                                  bool values, double k) {
  std::vector<std::vector<std::string>> rows;
  for (const ErrorsAtAngle& ea : errors) {
    std::vector<std::string> r = {fmt_num(ea.angle_deg, 6)};
    for (int e = 0; e < 6; ++e) {
      const Determined& d = ea.errors[e];
      std::ostringstream c;
      c << std::fixed << std::setprecision(2);
      if (!d.determined) {
        c << "--";
      } else if (values) {
        c << d.value << " ± " << k * d.std;
      } else {
        c << k * d.std;
      }
      r.push_back(c.str());
    }
    rows.push_back(r);
  }
  return rows;
}

}  // namespace dbbkit::io
