// Small helpers shared by the studies in tests/bench (study_*.cpp): CSV output, statistics,
// command-line flags, orientation helpers and the synthetic rib scene. The studies measure; they
// are not tests and never gate CI.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "base/vec.hpp"
#include "base/volume.hpp"
#include "prep/maps/distance_transform.hpp"

namespace palp::study {

// A CSV file with a header row; fields are numbers (printed with %.6g) or strings (quoted when
// they hold a comma).
class Csv {
 public:
  using Field = std::variant<double, std::string>;

  Csv(const std::string& path, std::initializer_list<std::string_view> header) : path_(path) {
    f_ = std::fopen(path.c_str(), "w");
    if (!f_) throw std::runtime_error("cannot write " + path);
    bool first = true;
    for (std::string_view h : header) {
      std::fprintf(f_, "%s%.*s", first ? "" : ",", static_cast<int>(h.size()), h.data());
      first = false;
    }
    std::fputc('\n', f_);
    columns_ = header.size();
  }
  Csv(const Csv&) = delete;
  Csv& operator=(const Csv&) = delete;
  ~Csv() {
    if (f_) std::fclose(f_);
  }

  void row(std::initializer_list<Field> fields) {
    if (fields.size() != columns_) throw std::logic_error("CSV row width differs from header");
    bool first = true;
    for (const Field& field : fields) {
      if (!first) std::fputc(',', f_);
      first = false;
      if (const double* d = std::get_if<double>(&field))
        std::fprintf(f_, "%.6g", *d);
      else
        write_text(std::get<std::string>(field));
    }
    std::fputc('\n', f_);
  }
  const std::string& path() const { return path_; }

 private:
  // Quoted (quotes doubled) when it holds a comma, a quote or a line break.
  void write_text(const std::string& t) {
    if (t.find_first_of(",\"\n") == std::string::npos) {
      std::fputs(t.c_str(), f_);
      return;
    }
    std::fputc('"', f_);
    for (char c : t) {
      if (c == '"') std::fputc('"', f_);
      std::fputc(c, f_);
    }
    std::fputc('"', f_);
  }

  std::string path_;
  std::FILE* f_ = nullptr;
  std::size_t columns_ = 0;
};

inline double percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(pos);
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (v[hi] - v[lo]) * (pos - static_cast<double>(lo));
}
inline double median(std::vector<double> v) {
  return percentile(std::move(v), 0.5);
}

// v printed with the printf format f (one conversion), "n/a" for NaN (a figure not measured).
inline std::string fmt(double v, const char* f) {
  if (std::isnan(v)) return "n/a";
  char b[32];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

inline double now_seconds() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

// Command-line flags of the studies: --out DIR (default "."), --quick (fewer samples).
struct Flags {
  std::string out_dir = ".";
  bool quick = false;
};
inline Flags parse_flags(int argc, char** argv, const char* usage) {
  Flags f;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a == "--out" && i + 1 < argc) {
      f.out_dir = argv[++i];
    } else if (a == "--quick") {
      f.quick = true;
    } else {
      std::fprintf(stderr, "usage: %s\n", usage);
      std::exit(2);
    }
  }
  std::filesystem::create_directories(f.out_dir);
  return f;
}

inline Vec3d normalized(const Vec3d& v) {
  const double n = norm(v);
  return n > 0.0 ? v * (1.0 / n) : Vec3d{0.0, 0.0, 1.0};
}

// The unit quaternion rotating unit vector a onto unit vector b (the shortest arc).
inline Quat rotation_between(const Vec3d& a, const Vec3d& b) {
  const double d = dot(a, b);
  if (d < -1.0 + 1e-12) {
    // Opposite: half a turn about any axis perpendicular to a.
    const Vec3d axis =
        normalized(std::fabs(a.x) < 0.9 ? cross(a, Vec3d{1, 0, 0}) : cross(a, Vec3d{0, 1, 0}));
    return {0.0, axis.x, axis.y, axis.z};
  }
  const Vec3d c = cross(a, b);
  const Quat q{1.0 + d, c.x, c.y, c.z};
  return palp::normalized(q);
}

// A flat skin and one thin rib under it, on an isotropic grid of spacing h (mm):
//   skin: the plane z = skin_z, body below (D_surf from the voxelised half space);
//   rib:  a bar along y of width `width` (x) and height `height` (z) whose top lies `depth` mm
//         under the skin, centred at x = rib_x, with an elliptic cross-section (a rectangular
//         one when round = false); voxelised (centre inside) at spacing h, so a thin rib at CT
//         resolution is only a few voxels across.
struct RibScene {
  double h = 1.0;
  double size_x = 80.0, size_y = 40.0, size_z = 60.0;  // grid extent (mm)
  double skin_z = 40.0;
  double rib_x = 40.0;
  double width = 6.0, height = 4.0, depth = 8.0;
  bool round = true;
};

struct RibMaps {
  DistanceMap surf, bone;
  double skin_level = 0.0;                 // z of the voxelised skin surface (mm)
  double rib_top = 0.0, rib_bottom = 0.0;  // z of the voxelised rib's faces (mm)
};

inline RibMaps make_rib_maps(const RibScene& s) {
  Grid g;
  g.dims = {static_cast<std::int64_t>(std::llround(s.size_x / s.h)) + 1,
            static_cast<std::int64_t>(std::llround(s.size_y / s.h)) + 1,
            static_cast<std::int64_t>(std::llround(s.size_z / s.h)) + 1};
  g.spacing = {s.h, s.h, s.h};
  Mask body(g, 0, "rib scene body"), bone(g, 0, "rib scene bone");
  const double top = s.skin_z - s.depth, bottom = top - s.height;
  double vox_top = -1e300, vox_bottom = 1e300;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const double x = static_cast<double>(i) * s.h, z = static_cast<double>(k) * s.h;
        body.at(i, j, k) = z <= s.skin_z ? 1 : 0;
        const double ex = (x - s.rib_x) / (0.5 * s.width);
        const double ez = (z - 0.5 * (top + bottom)) / (0.5 * s.height);
        const bool in_rib =
            s.round ? ex * ex + ez * ez <= 1.0 : std::fabs(ex) <= 1.0 && z <= top && z >= bottom;
        bone.at(i, j, k) = in_rib ? 1 : 0;
        if (in_rib) {
          vox_top = std::max(vox_top, z + 0.5 * s.h);
          vox_bottom = std::min(vox_bottom, z - 0.5 * s.h);
        }
      }
  RibMaps m;
  m.surf = signed_distance(body);
  m.bone = signed_distance(bone);
  m.skin_level = (std::floor(s.skin_z / s.h) + 0.5) * s.h;
  m.rib_top = vox_top;
  m.rib_bottom = vox_bottom;
  return m;
}

}  // namespace palp::study
