// The report's two charts per trial (report.hpp): force over time, and the path over the skin in
// the task's view with the anatomy, the target and the marks.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "training/report.hpp"
#include "training/svg.hpp"

namespace palp::training {
namespace {

constexpr const char* kTargetColour = "#1a9850";
constexpr const char* kMissColour = "#d73027";
constexpr const char* kPathColour = "#2166ac";
constexpr const char* kBoneColour = "#bdbdbd";

// Decimals that tell ticks `step` apart.
int decimals_for(const std::vector<double>& ticks) {
  if (ticks.size() < 2) return 1;
  const double step = ticks[1] - ticks[0];
  return step >= 1.0 ? 0 : std::min(4, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
}

// A rectangle of the chart in pixels and the data range it shows.
struct Frame {
  double left, top, width, height;
  double x0, x1, y0, y1;
  SvgPoint at(double x, double y) const {
    const double fx = x1 > x0 ? (x - x0) / (x1 - x0) : 0.5;
    const double fy = y1 > y0 ? (y - y0) / (y1 - y0) : 0.5;
    return {left + fx * width, top + (1.0 - fy) * height};
  }
  double scale_x() const { return x1 > x0 ? width / (x1 - x0) : 1.0; }
};

void axes(Svg& svg, const Frame& f, const std::string& x_label, const std::string& y_label) {
  const SvgStyle grid{"#e0e0e0", "none", 1.0, "", 1.0};
  const std::vector<double> xs = nice_ticks(f.x0, f.x1);
  const std::vector<double> ys = nice_ticks(f.y0, f.y1, 4);
  for (const double x : xs) {
    const SvgPoint p = f.at(x, f.y0);
    svg.line({p.x, f.top}, {p.x, f.top + f.height}, grid);
    svg.text({p.x, f.top + f.height + 14.0}, fixed(x, decimals_for(xs)), 11.0, "middle");
  }
  for (const double y : ys) {
    const SvgPoint p = f.at(f.x0, y);
    svg.line({f.left, p.y}, {f.left + f.width, p.y}, grid);
    svg.text({f.left - 5.0, p.y + 4.0}, fixed(y, decimals_for(ys)), 11.0, "end");
  }
  svg.rect({f.left, f.top}, f.width, f.height, SvgStyle{"#444", "none", 1.0, "", 1.0});
  svg.text({f.left + f.width / 2.0, f.top + f.height + 30.0}, x_label, 12.0, "middle");
  svg.text({f.left, f.top - 6.0}, y_label, 12.0, "start");
}

// The force curve with at most two points per pixel column (the column's min and max, in time
// order), so a ten-minute trial draws as fast as a short one.
std::vector<SvgPoint> force_curve(const std::vector<TrialSample>& samples, const Frame& f) {
  std::vector<SvgPoint> points;
  std::size_t i = 0;
  while (i < samples.size()) {
    const double column = std::floor(f.at(samples[i].t, 0.0).x);
    std::size_t lo = i, hi = i, j = i;
    for (; j < samples.size() && std::floor(f.at(samples[j].t, 0.0).x) == column; ++j) {
      if (samples[j].normal_force < samples[lo].normal_force) lo = j;
      if (samples[j].normal_force > samples[hi].normal_force) hi = j;
    }
    for (const std::size_t k : {std::min(lo, hi), std::max(lo, hi)})
      points.push_back(f.at(samples[k].t, samples[k].normal_force));
    i = j;
  }
  return points;
}

// The chart's range of `up` and `across`: the path, the marks and the target, padded, square.
struct Box {
  double a0 = -30.0, a1 = 30.0, u0 = -30.0, u1 = 30.0;
};
Box view_box(const TaskView& view, const Trial& trial) {
  double a0 = 0.0, a1 = 0.0, u0 = 0.0, u1 = 0.0;  // the target is the origin
  auto grow = [&](const Vec3d& p) {
    const ViewPoint v = project(view, p);
    a0 = std::min(a0, v.across), a1 = std::max(a1, v.across);
    u0 = std::min(u0, v.up), u1 = std::max(u1, v.up);
  };
  for (const TrialSample& s : trial.samples)
    if (s.in_contact) grow(s.skin_point);
  for (const Mark& m : trial.marks) grow(m.point);
  const double half = std::max({30.0, (a1 - a0) / 2.0 + 15.0, (u1 - u0) / 2.0 + 15.0});
  const double ac = (a0 + a1) / 2.0, uc = (u0 + u1) / 2.0;
  return {ac - half, ac + half, uc - half, uc + half};
}

// The path in contact as polylines (a break where contact was lost), points 0.25 mm apart or
// more.
std::vector<std::vector<SvgPoint>> contact_paths(const TaskView& view, const Trial& trial,
                                                 const Frame& f) {
  std::vector<std::vector<SvgPoint>> paths;
  bool open = false;
  ViewPoint last{};
  for (const TrialSample& s : trial.samples) {
    if (!s.in_contact) {
      open = false;
      continue;
    }
    const ViewPoint v = project(view, s.skin_point);
    if (!open) {
      paths.emplace_back();
      open = true;
    } else if (std::hypot(v.across - last.across, v.up - last.up) < 0.25) {
      continue;
    }
    paths.back().push_back(f.at(v.across, v.up));
    last = v;
  }
  return paths;
}

// The anatomy the marks are placed against, drawn under the path.
void draw_anatomy(Svg& svg, const Session& session, const TaskView& view, const Frame& f) {
  const TaskTarget& target = session.target;
  const double px_per_mm = f.scale_x();
  const SvgStyle bone{kBoneColour, "none", 2.0 * kRibHalfWidthMm * px_per_mm, "", 0.7};
  const auto inside = [&](const SvgPoint& p) {
    return p.x >= f.left && p.x <= f.left + f.width && p.y >= f.top && p.y <= f.top + f.height;
  };
  if (target.spec.kind == TaskKind::ptcd) {
    for (const auto& rib : session.landmarks.ribs) {
      if (rib.side != target.spec.side || !rib.number) continue;
      std::vector<SvgPoint> line;
      for (const Vec3d& p : rib.points) {
        const ViewPoint v = project(view, p);
        line.push_back(f.at(v.across, v.up));
      }
      svg.polyline(line, bone);
      const auto label = std::find_if(line.begin(), line.end(), inside);
      if (label != line.end())
        svg.text({std::max(label->x, f.left + 4.0), label->y + 4.0},
                 "rib " + std::to_string(*rib.number), 11.0, "start", "#555");
    }
  } else if (target.spec.kind == TaskKind::lumbar) {
    const double half_w = 10.0 * px_per_mm, half_h = kSpinousHalfHeightMm * px_per_mm;
    for (const auto& v : session.landmarks.vertebrae) {
      if (!v.spinous_tip) continue;
      const ViewPoint tip = project(view, *v.spinous_tip);
      const SvgPoint c = f.at(tip.across, tip.up);
      svg.rect({c.x - half_w, c.y - half_h}, 2.0 * half_w, 2.0 * half_h,
               SvgStyle{"#888", kBoneColour, 1.0, "", 0.7});
      svg.text({c.x + half_w + 4.0, c.y + 4.0}, v.name ? *v.name : "?", 11.0, "start", "#555");
    }
  } else {
    svg.circle(f.at(0.0, 0.0), target.radius_mm * px_per_mm,
               SvgStyle{kTargetColour, "none", 1.5, "4 3", 1.0});
  }
}

void draw_target(Svg& svg, const Frame& f, const std::string& label) {
  const SvgPoint c = f.at(0.0, 0.0);
  const SvgStyle cross{kTargetColour, "none", 2.0, "", 1.0};
  svg.line({c.x - 9.0, c.y}, {c.x + 9.0, c.y}, cross);
  svg.line({c.x, c.y - 9.0}, {c.x, c.y + 9.0}, cross);
  svg.text({c.x + 10.0, c.y - 6.0}, label, 11.0, "start", kTargetColour);
}

void draw_marks(Svg& svg, const TaskView& view, const Trial& trial, const Frame& f) {
  for (std::size_t i = 0; i < trial.score.marks.size(); ++i) {
    const MarkScore& m = trial.score.marks[i];
    const ViewPoint v = project(view, m.mark.point);
    const SvgPoint c = f.at(v.across, v.up);
    const char* colour = m.in_target ? kTargetColour : kMissColour;
    svg.circle(c, 6.0, SvgStyle{"white", colour, 1.5, "", 1.0});
    svg.text({c.x, c.y + 4.0}, std::to_string(i + 1), 9.0, "middle", "white");
  }
}

// The patient direction nearest to a view axis (LPS: +x left, +y posterior, +z superior).
const char* direction_name(const Vec3d& axis) {
  const double c[3] = {axis.x, axis.y, axis.z};
  static const char* kNames[3][2] = {
      {"left", "right"}, {"posterior", "anterior"}, {"superior", "inferior"}};
  int best = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(c[i]) > std::abs(c[best])) best = i;
  return kNames[best][c[best] >= 0.0 ? 0 : 1];
}

}  // namespace

std::string force_chart_svg(const Trial& trial) {
  Svg svg(640.0, 260.0);
  double t0 = 0.0, t1 = 1.0;
  if (!trial.samples.empty()) {
    t0 = trial.samples.front().t;
    t1 = std::max(trial.samples.back().t, t0 + 1e-3);
  }
  for (const Mark& m : trial.marks) t1 = std::max(t1, m.t);
  const double top = std::max(1.0, trial.score.peak_force_n * 1.1);
  const Frame f{55.0, 25.0, 565.0, 190.0, t0, t1, 0.0, top};
  axes(svg, f, "time (s)", "normal force (N)");
  svg.polyline(force_curve(trial.samples, f), SvgStyle{kPathColour, "none", 1.5, "", 1.0});
  for (std::size_t i = 0; i < trial.score.marks.size(); ++i) {
    const MarkScore& m = trial.score.marks[i];
    const SvgPoint p = f.at(m.mark.t, 0.0);
    const char* colour = m.in_target ? kTargetColour : kMissColour;
    svg.line({p.x, f.top}, {p.x, f.top + f.height}, SvgStyle{colour, "none", 1.5, "5 3", 1.0});
    svg.text({p.x + 3.0, f.top + 12.0}, std::to_string(i + 1), 11.0, "start", colour);
  }
  return svg.str();
}

std::string path_chart_svg(const Session& session, const Trial& trial) {
  const TaskView view = task_view(session.target);
  const Box box = view_box(view, trial);
  Svg svg(500.0, 500.0);
  const Frame f{55.0, 25.0, 420.0, 420.0, box.a0, box.a1, box.u0, box.u1};
  axes(svg, f, std::string("mm towards the patient's ") + direction_name(view.across),
       std::string("mm towards ") + direction_name(view.up));
  svg.text({f.left + f.width, f.top - 6.0},
           std::string("seen from the ") + direction_name(view.normal), 12.0, "end", "#555");
  svg.begin_clip({f.left, f.top}, f.width, f.height);
  draw_anatomy(svg, session, view, f);
  for (const auto& path : contact_paths(view, trial, f))
    svg.polyline(path, SvgStyle{kPathColour, "none", 1.5, "", 0.9});
  draw_target(svg, f, "target");
  draw_marks(svg, view, trial, f);
  svg.end_clip();
  return svg.str();
}

}  // namespace palp::training
