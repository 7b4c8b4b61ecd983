// Synthetic CTs: the cube and sphere (crisp, exact geometry), the public entry points and the
// options' parsing; the torso itself is drawn in phantom_torso.cpp (see phantom.hpp for the
// anatomy and the options).
#include "io/phantom.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <string_view>

#include "base/axis_order.hpp"
#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "io/phantom_shapes.hpp"

namespace palp {
namespace {

using namespace phantom_detail;

// ---------------------------------------------------------------------------------------------
// Grids

struct PhantomDefaults {
  Index3 dims;
  Vec3 spacing;
};

PhantomDefaults defaults_for(const std::string& name) {
  if (name == "cube") return {{140, 140, 140}, {1.0, 1.0, 1.0}};
  if (name == "sphere") return {{100, 100, 100}, {1.0, 1.0, 1.0}};
  if (name == "torso") return {{384, 256, 96}, {1.25, 1.25, 2.0}};
  if (name == "trunk") return {{160, 120, 187}, {2.5, 2.5, 3.0}};
  std::string known;
  for (const auto& n : phantom_names()) known += (known.empty() ? "" : ", ") + n;
  throw UsageError("unknown phantom '" + name + "' (known: " + known + ")");
}

// Cube and sphere: crisp (a voxel is tissue when its centre is inside), no noise.
template <class Inside>
CtVolume draw_crisp(const Grid& grid, PhantomTruth* truth, Inside inside) {
  CtVolume ct(grid, 0, "phantom");
  if (truth) *truth = empty_truth(grid, "phantom truth");
  parallel_for_chunks(grid.dims[2], 4, [&](std::int64_t k_begin, std::int64_t k_end) {
    for (std::int64_t k = k_begin; k < k_end; ++k) {
      for (std::int64_t j = 0; j < grid.dims[1]; ++j) {
        for (std::int64_t i = 0; i < grid.dims[0]; ++i) {
          const Vec3 p{static_cast<double>(i) * grid.spacing[0],
                       static_cast<double>(j) * grid.spacing[1],
                       static_cast<double>(k) * grid.spacing[2]};
          const bool in = inside(p);
          const std::size_t n = grid.linear(i, j, k);
          ct.data[n] = to_hu(in ? kSoftTissueHu : kAirHu);
          if (truth) truth->body.data[n] = in ? 1 : 0;
        }
      }
    }
  });
  return ct;
}

// ---------------------------------------------------------------------------------------------
// Options

template <class T>
T parse_value(std::string_view text, const std::string& key) {
  T value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || text.empty())
    throw UsageError("phantom option " + key + " needs a number, got '" + std::string(text) + "'");
  return value;
}

template <class T>
std::array<T, 3> parse_triple_value(const std::string& text, const std::string& key) {
  std::array<T, 3> out{};
  std::size_t start = 0;
  for (int a = 0; a < 3; ++a) {
    const std::size_t x = a < 2 ? text.find_first_of("xX", start) : text.size();
    if (x == std::string::npos)
      throw UsageError("phantom option " + key + " needs NXxNYxNZ, got '" + text + "'");
    out[a] = parse_value<T>(std::string_view(text).substr(start, x - start), key);
    start = x + 1;
  }
  return out;
}

bool parse_switch(const std::string& text, const std::string& key) {
  if (text == "1" || text == "true" || text == "on" || text == "yes") return true;
  if (text == "0" || text == "false" || text == "off" || text == "no") return false;
  throw UsageError("phantom option " + key + " needs 1 or 0, got '" + text + "'");
}

void check_options(const std::string& name, const PhantomOptions& o) {
  if (name == "trunk" && (o.arms != 1 || o.metal || o.dissection || o.level_mm != 0.0))
    throw UsageError("phantom trunk has no arms, level, metal or dissection (torso only)");
  if (name != "torso" && name != "trunk" &&
      (o.contrast || o.aorta_hu || o.arms != 1 || o.metal || o.structures || o.dissection ||
       o.level_mm != 0.0))
    throw UsageError("phantom " + name +
                     " has no contrast, aorta-hu, arms, level, metal, structures or dissection "
                     "(the torso's options; the trunk takes contrast, aorta-hu and structures)");
  if (o.arms < 0 || o.arms > 2)
    throw UsageError("phantom option arms needs 0, 1 or 2, got " + std::to_string(o.arms));
  if (o.aorta_hu && !(*o.aorta_hu >= -1000.0 && *o.aorta_hu <= 3000.0))
    throw UsageError("phantom option aorta-hu needs a value in [-1000, 3000] HU");
  if (!(o.level_mm >= -200.0 && o.level_mm <= 200.0))
    throw UsageError("phantom option level needs a value in [-200, 200] mm");
}

// What only the whole set of options can say (set_phantom_option checks each as it comes, so
// the order of a scene string's keys cannot matter here).
void check_combination(const PhantomOptions& o) {
  if (o.dissection && o.structures && !o.contrast && !o.aorta_hu)
    throw UsageError(
        "phantom option dissection with structures needs contrast or aorta-hu (the "
        "vessel tree, whose aorta it dissects)");
}

Grid own_grid(const std::string& name, const PhantomOptions& options);
CtVolume draw_phantom(const std::string& name, const PhantomOptions& options, PhantomTruth* truth);

}  // namespace

const char* phantom_contrast_name(PhantomContrast contrast) {
  switch (contrast) {
    case PhantomContrast::none:
      return "none";
    case PhantomContrast::arterial:
      return "arterial";
    case PhantomContrast::portal_venous:
      return "portal-venous";
  }
  return "?";
}

void set_phantom_option(PhantomOptions& options, const std::string& key, const std::string& value) {
  if (key == "dims") {
    options.dims = parse_triple_value<std::int64_t>(value, key);
  } else if (key == "spacing") {
    options.spacing = parse_triple_value<double>(value, key);
  } else if (key == "contrast") {
    for (PhantomContrast c :
         {PhantomContrast::none, PhantomContrast::arterial, PhantomContrast::portal_venous})
      if (value == phantom_contrast_name(c)) options.contrast = c;
    if (!options.contrast || value != phantom_contrast_name(*options.contrast))
      throw UsageError("phantom option contrast needs none, arterial or portal-venous, got '" +
                       value + "'");
  } else if (key == "aorta-hu") {
    options.aorta_hu = parse_value<double>(value, key);
  } else if (key == "arms") {
    options.arms = parse_value<int>(value, key);
  } else if (key == "metal") {
    options.metal = parse_switch(value, key);
  } else if (key == "structures") {
    options.structures = parse_switch(value, key);
  } else if (key == "dissection") {
    options.dissection = parse_switch(value, key);
  } else if (key == "level") {
    options.level_mm = parse_value<double>(value, key);
  } else if (key == "orient") {
    axis_reorder(Grid{{1, 1, 1}, {1.0, 1.0, 1.0}, {}}, value);  // UsageError for a bad code
    options.orient = value;
  } else {
    throw UsageError("unknown phantom option '" + key +
                     "' (known: dims, spacing, contrast, aorta-hu, arms, level, metal, "
                     "structures, dissection, orient)");
  }
  check_options("torso", options);
}

PhantomSpec parse_phantom_spec(const std::string& text) {
  PhantomSpec spec;
  std::size_t start = 0;
  bool first = true;
  while (true) {
    const std::size_t comma = text.find(',', start);
    const std::string item =
        text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (first) {
      spec.name = item;
      first = false;
    } else {
      const std::size_t eq = item.find('=');
      if (eq == std::string::npos && item != "metal" && item != "structures" &&
          item != "dissection")
        throw UsageError("phantom option '" + item +
                         "' needs KEY=VALUE (or a flag: metal, structures, dissection)");
      set_phantom_option(spec.options, item.substr(0, eq),
                         eq == std::string::npos ? "1" : item.substr(eq + 1));
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  check_options(spec.name, spec.options);
  check_combination(spec.options);
  return spec;
}

std::vector<std::string> phantom_names() {
  return {"cube", "sphere", "torso", "trunk"};
}

Grid phantom_grid(const std::string& name, const PhantomOptions& options) {
  const Grid grid = own_grid(name, options);
  return options.orient ? axis_reorder(grid, *options.orient).grid : grid;
}

namespace {

// The phantom's grid in its own axis order (LPS for the sphere, torso and trunk, ILA for the cube).
Grid own_grid(const std::string& name, const PhantomOptions& options) {
  const PhantomDefaults d = defaults_for(name);
  Grid grid;
  grid.dims = options.dims.value_or(d.dims);
  grid.spacing = options.spacing.value_or(d.spacing);
  try {
    validate_grid(grid, "phantom " + name);
  } catch (const InputError& e) {
    throw UsageError(e.what());
  }
  const Vec3 e = grid.extent_mm();
  grid.world.origin = {-e[0] / 2.0, -e[1] / 2.0, -e[2] / 2.0};
  if (name == "cube") {
    // "ILA": i toward inferior, j toward the left, k toward anterior (the top face). Columns of
    // the row-major direction are the i, j, k directions in LPS; origin = -D (extent / 2).
    grid.world.direction = {0, 1, 0, 0, 0, -1, -1, 0, 0};
    grid.world.origin = {-e[1] / 2.0, e[2] / 2.0, e[0] / 2.0};
  }
  return grid;
}

}  // namespace

SphereGeometry sphere_geometry(const Grid& grid) {
  return {grid_centre(grid), 30.0 * fit_scale(grid, {100.0, 100.0, 100.0}, 3)};
}

BoxGeometry cube_geometry(const Grid& grid) {
  const double side = 100.0 * fit_scale(grid, {140.0, 140.0, 140.0}, 3);
  BoxGeometry box{};
  for (int a = 0; a < 3; ++a) {
    const std::int64_t n = grid.dims[a];
    const std::int64_t inside = std::clamp<std::int64_t>(std::llround(side / grid.spacing[a]), 1,
                                                         std::max<std::int64_t>(1, n - 2));
    const std::int64_t first = (n - inside) / 2;
    box.min[a] = (static_cast<double>(first) - 0.5) * grid.spacing[a];
    box.max[a] = (static_cast<double>(first + inside) - 0.5) * grid.spacing[a];
  }
  return box;
}

CtVolume make_phantom(const std::string& name, const PhantomOptions& options, PhantomTruth* truth) {
  check_options(name, options);
  check_combination(options);
  if (!options.orient) return draw_phantom(name, options, truth);
  PhantomOptions own = options;
  own.orient.reset();
  CtVolume ct = draw_phantom(name, own, truth);
  const AxisReorder reorder = axis_reorder(ct.grid, *options.orient);
  if (truth) {
    for (Mask* m : {&truth->body, &truth->bone, &truth->equipment, &truth->vessel, &truth->artery,
                    &truth->metal, &truth->liver, &truth->bone_label})
      if (!m->data.empty()) *m = reorder_volume(*m, reorder, "phantom truth");
  }
  return reorder_volume(ct, reorder, "phantom");
}

namespace {

CtVolume draw_phantom(const std::string& name, const PhantomOptions& options, PhantomTruth* truth) {
  const Grid grid = own_grid(name, options);
  if (name == "torso") return draw_torso(grid, options, truth);
  if (name == "trunk") return draw_trunk(grid, options, truth);
  if (name == "sphere") {
    const SphereGeometry s = sphere_geometry(grid);
    return draw_crisp(grid, truth, [s](const Vec3& p) {
      const double dx = p[0] - s.centre[0], dy = p[1] - s.centre[1], dz = p[2] - s.centre[2];
      return dx * dx + dy * dy + dz * dz <= s.radius * s.radius;
    });
  }
  const BoxGeometry b = cube_geometry(grid);
  return draw_crisp(grid, truth, [b](const Vec3& p) {
    for (int a = 0; a < 3; ++a)
      if (p[a] < b.min[a] || p[a] > b.max[a]) return false;
    return true;
  });
}

}  // namespace

}  // namespace palp