// Speed against accuracy of the force loop: distance-map resolution (0.5, 1, 2, 3 mm) x gradient
// scheme (analytic trilinear, central differences, precomputed field) x storage (float32, int16,
// interleaved). For each configuration a finger:37 presses and slides at many random poses; the
// force of every tick is compared with the same tick on a high-resolution reference, and the
// tick is timed (median of repetitions).
//
//   sphere  the analytic sphere phantom's geometry (skin radius 30 mm) with a concentric bone
//           ball (radius 20 mm). Reference: the exact signed distances of both balls sampled at
//           0.25 mm (not voxelised; the trilinear error of that is ~h^2/(8R) = 3e-4 mm). Test
//           maps: voxelised masks (centre inside) -> palp::signed_distance, as prep makes them.
//   torso   palp::make_phantom("torso") truth masks (body, bone) -> palp::signed_distance. The
//           whole torso at 0.25 mm would be 1.9e9 voxels, so every grid here is a slab of the
//           torso's full cross-section (480 x 324 mm, the anatomy is not scaled) 24 mm thick
//           around the rib level (z = -12..12 mm), the reference at 0.25 mm (2.4e8 voxels).
//           Poses press on the anterior chest wall over the ribs, pad within |z| <= 4 mm.
//
// Writes speed_accuracy.csv (one row per phantom x configuration, with a pareto column) and
// prints the Pareto fronts and the defaults they suggest.
//
//   study_speed_accuracy [--out DIR] [--quick] [--no-torso]
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "bench/study_util.hpp"
#include "io/phantom.hpp"
#include "model/field_sampler.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"
#include "prep/maps/distance_transform.hpp"

namespace palp::study {
namespace {

constexpr double kResolutions[] = {0.5, 1.0, 2.0, 3.0};
constexpr double kReferenceResolution = 0.25;
constexpr GradientScheme kSchemes[] = {GradientScheme::AnalyticTrilinear,
                                       GradientScheme::CentralDifference,
                                       GradientScheme::PrecomputedField};
constexpr Storage kStorages[] = {Storage::Float32, Storage::Int16, Storage::Interleaved};

constexpr int kSlideTicks = 40;       // per pose
constexpr double kSlideStep = 0.1;    // mm per tick (100 mm/s at 1 kHz)
constexpr double kMaxTiltDeg = 15.0;  // tool axis tilt from the skin normal

// A pose sequence: press at a pose, then slide along the skin.
using Sequence = std::vector<Pose>;

struct Maps {
  DistanceMap surf, bone;
  Vec3d offset{};  // added to the reference-frame poses for this grid
};

struct PhantomCase {
  std::string name;
  std::function<Maps(double h)> maps;  // test maps at spacing h (and the reference at 0.25)
  std::function<std::vector<Sequence>(const FieldSampler& ref, std::mt19937_64& rng, int n)> poses;
  // The exact device force of a first tick (no friction yet), where the geometry is analytic.
  std::function<Vec3d(const Tool& tool, const Pose& pose)> analytic;
};

// A pose whose tool axis (+z of the tool) points along `normal`, tilted and spun at random, with
// the pad centre `depth` mm inside along the normal from `skin_point`; the slide follows a random
// tangent.
Sequence make_sequence(const Vec3d& skin_point, const Vec3d& normal, double depth,
                       std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const double pi = 3.14159265358979323846;
  const Quat align = rotation_between({0, 0, 1}, normal);
  const Quat spin = axis_angle({0, 0, 1}, 2.0 * pi * u01(rng));
  const double tilt = kMaxTiltDeg * pi / 180.0 * u01(rng);
  const double tilt_az = 2.0 * pi * u01(rng);
  const Quat tilt_q = axis_angle({std::cos(tilt_az), std::sin(tilt_az), 0.0}, tilt);
  const Quat q = multiply(align, multiply(tilt_q, spin));
  const Vec3d axis = rotate(q, {0, 0, 1});
  // Tangent for the slide.
  const Vec3d any = std::fabs(normal.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
  const Vec3d t1 = normalized(cross(normal, any));
  const Vec3d t2 = cross(normal, t1);
  const double a = 2.0 * pi * u01(rng);
  const Vec3d tangent = std::cos(a) * t1 + std::sin(a) * t2;
  // Device point: the pad centre (8 mm along -axis from it) at the pressing depth.
  const Vec3d pad = skin_point - depth * normal;
  const Vec3d device = pad + kFingerPadZ * -1.0 * axis;
  Sequence seq;
  for (int t = 0; t < kSlideTicks; ++t) seq.push_back(Pose{device + (kSlideStep * t) * tangent, q});
  return seq;
}

// ---------------------------------------------------------------------------------------------
// Sphere: skin ball R = 30 mm, bone ball 20 mm, centred in an 84 mm cube (84 is a multiple of
// every spacing, so the centre is the same point at every resolution).

constexpr double kSphereSide = 84.0, kSphereR = 30.0, kSphereBoneR = 20.0;
const Vec3d kSphereC{42.0, 42.0, 42.0};

Grid cube_grid(double h) {
  Grid g;
  const auto n = static_cast<std::int64_t>(std::llround(kSphereSide / h)) + 1;
  g.dims = {n, n, n};
  g.spacing = {h, h, h};
  return g;
}

Maps sphere_maps(double h) {
  const Grid g = cube_grid(h);
  Maps m;
  if (h == kReferenceResolution) {
    // Exact signed distances at the voxel centres.
    m.surf = DistanceMap(g, 0.0f, "sphere reference");
    m.bone = DistanceMap(g, 0.0f, "sphere reference");
    for (std::int64_t k = 0; k < g.dims[2]; ++k)
      for (std::int64_t j = 0; j < g.dims[1]; ++j)
        for (std::int64_t i = 0; i < g.dims[0]; ++i) {
          const Vec3d p{static_cast<double>(i) * h, static_cast<double>(j) * h,
                        static_cast<double>(k) * h};
          const double r = norm(p - kSphereC);
          m.surf.at(i, j, k) = static_cast<float>(kSphereR - r);
          m.bone.at(i, j, k) = static_cast<float>(kSphereBoneR - r);
        }
    return m;
  }
  Mask body(g, 0, "sphere mask"), bone(g, 0, "sphere mask");
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const Vec3d p{static_cast<double>(i) * h, static_cast<double>(j) * h,
                      static_cast<double>(k) * h};
        const double r = norm(p - kSphereC);
        body.at(i, j, k) = r <= kSphereR ? 1 : 0;
        bone.at(i, j, k) = r <= kSphereBoneR ? 1 : 0;
      }
  m.surf = signed_distance(body);
  m.bone = signed_distance(bone);
  return m;
}

std::vector<Sequence> sphere_poses(const FieldSampler&, std::mt19937_64& rng, int n) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> depth(0.5, 9.0);
  std::vector<Sequence> out;
  for (int i = 0; i < n; ++i) {
    const Vec3d u = normalized({gauss(rng), gauss(rng), gauss(rng)});
    out.push_back(make_sequence(kSphereC + kSphereR * u, u, depth(rng), rng));
  }
  return out;
}

// Steps 1-5 and 11-12 on the exact balls: every point in contact pushed out radially by the skin
// law plus the bone law (v_b . v_s = 1, so d_bone = v_b).
Vec3d sphere_analytic(const Tool& tool, const Pose& pose) {
  const Quat q = palp::normalized(pose.orientation);
  Vec3d sum{};
  int n = 0;
  for (const Vec3d& pt : tool.points) {
    const Vec3d x = pose.position + rotate(q, pt);
    const double r = norm(x - kSphereC);
    const double depth = kSphereR - r;
    if (!(depth > 0.0)) continue;
    const Vec3d out = (x - kSphereC) * (1.0 / r);
    sum += (surface_force(depth) + bone_force(r - kSphereBoneR, 40.0)) * out;
    ++n;
  }
  return n > 0 ? sum * (1.0 / n) : Vec3d{};
}

// ---------------------------------------------------------------------------------------------
// Torso slab.

constexpr double kTorsoX = 480.0, kTorsoY = 324.0, kTorsoZ = 24.0;  // multiples of 3 and 0.25

Maps torso_maps(double h) {
  PhantomOptions opt;
  opt.dims = Index3{std::llround(kTorsoX / h) + 1, std::llround(kTorsoY / h) + 1,
                    std::llround(kTorsoZ / h) + 1};
  opt.spacing = Vec3{h, h, h};
  PhantomTruth truth;
  { const CtVolume ct = make_phantom("torso", opt, &truth); }
  // The phantom snaps the table pad's top face between voxel rows, which shifts the anatomy in
  // y by up to half a voxel per grid: measure the pad's top face in a column beside the body
  // (anatomy x = -215 mm) and report it as this grid's offset.
  const Grid& g = truth.equipment.grid;
  const std::int64_t i = std::llround((kTorsoX / 2.0 - 215.0) / h);
  const std::int64_t k = g.dims[2] / 2;
  double pad_top = 0.0;
  for (std::int64_t j = 0; j < g.dims[1]; ++j)
    if (truth.equipment.at(i, j, k)) {
      pad_top = (static_cast<double>(j) - 0.5) * h;
      break;
    }
  truth.equipment = Mask();
  Maps m;
  m.surf = signed_distance(truth.body);
  truth.body = Mask();
  m.bone = signed_distance(truth.bone);
  m.offset = {0.0, pad_top, 0.0};  // made relative to the reference's by the caller
  return m;
}

std::vector<Sequence> torso_poses(const FieldSampler& ref, std::mt19937_64& rng, int n) {
  std::uniform_real_distribution<double> ux(kTorsoX / 2.0 - 100.0, kTorsoX / 2.0 + 150.0);
  std::uniform_real_distribution<double> uz(kTorsoZ / 2.0 - 4.0, kTorsoZ / 2.0 + 4.0);
  std::uniform_real_distribution<double> depth(2.0, 16.0);
  std::vector<Sequence> out;
  int tries = 0;
  while (static_cast<int>(out.size()) < n && ++tries < 100 * n) {
    const double x = ux(rng), z = uz(rng);
    // March in from the anterior side (small y) to the skin.
    double y = 1.0;
    while (y < kTorsoY / 2.0 && !(ref.sample_surf({x, y, z}).value > 0.0)) y += 0.25;
    if (!(y < kTorsoY / 2.0)) continue;
    const Vec3d skin{x, y, z};
    const FieldSample s = ref.sample_surf(skin);
    if (norm(s.grad) < 0.5) continue;
    const Vec3d normal = s.grad * (-1.0 / norm(s.grad));
    // Over the ribs: bone within 30 mm of the skin point.
    if (!(ref.sample_bone(skin).value > -30.0)) continue;
    out.push_back(make_sequence(skin, normal, depth(rng), rng));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------

struct Result {
  std::string phantom;
  double h;
  GradientScheme scheme;
  Storage storage;
  double tick_ns, err_rel_pct, err_mean, err_rms, err_p95;
  double bytes_per_voxel;
  bool pareto = false;
};

// Forces of every tick of every sequence (device force), the state reset at each sequence.
std::vector<Vec3d> run_forces(const Model& model, const std::vector<Sequence>& seqs,
                              const Vec3d& offset) {
  State st = make_state(model);
  std::vector<Vec3d> out;
  for (const Sequence& seq : seqs) {
    reset(st);
    for (Pose p : seq) {
      p.position += offset;
      tick(model, st, p);
      out.push_back(st.f_device);
    }
  }
  return out;
}

// Per-tick time (ns) of each sequence, timed one sequence at a time, so a burst of load from
// other processes spoils a few samples and not the median.
void time_ticks(const Model& model, const std::vector<Sequence>& seqs, const Vec3d& offset,
                std::vector<double>& samples) {
  State st = make_state(model);
  double sink = 0.0;
  for (const Sequence& seq : seqs) {
    reset(st);
    const double t0 = now_seconds();
    for (Pose p : seq) {
      p.position += offset;
      tick(model, st, p);
      sink += st.f_device.z;
    }
    samples.push_back((now_seconds() - t0) * 1e9 / static_cast<double>(seq.size()));
  }
  if (sink == 12345.678) std::puts("");  // keeps the loop
}

void mark_pareto(std::vector<Result>& rs) {
  for (Result& a : rs) {
    a.pareto = true;
    for (const Result& b : rs) {
      if (&a == &b) continue;
      const bool no_worse = b.tick_ns <= a.tick_ns && b.err_rel_pct <= a.err_rel_pct;
      const bool better = b.tick_ns < a.tick_ns || b.err_rel_pct < a.err_rel_pct;
      if (no_worse && better) {
        a.pareto = false;
        break;
      }
    }
  }
}

std::string config_name(const Result& r) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%g mm %s/%s", r.h, to_string(r.scheme), to_string(r.storage));
  return buf;
}

std::vector<Result> run_study(const PhantomCase& pc, int n_poses, int reps, std::mt19937_64& rng) {
  const Tool tool = parse_tool("finger:37");
  const double t_start = now_seconds();
  // Reference forces.
  Maps ref_maps = pc.maps(kReferenceResolution);
  const Vec3d ref_offset = ref_maps.offset;
  std::vector<Sequence> seqs;
  std::vector<Vec3d> ref_forces;
  {
    auto ref = std::make_shared<const FieldSampler>(std::move(ref_maps.surf),
                                                    std::move(ref_maps.bone), SamplerConfig{});
    seqs = pc.poses(*ref, rng, n_poses);
    const Model model(ref, tool);
    ref_forces = run_forces(model, seqs, {});
    std::printf("  %s: reference %lld x %lld x %lld at %.2f mm, %zu poses, %zu ticks (%.1f s)\n",
                pc.name.c_str(), static_cast<long long>(ref->grid().dims[0]),
                static_cast<long long>(ref->grid().dims[1]),
                static_cast<long long>(ref->grid().dims[2]), kReferenceResolution, seqs.size(),
                ref_forces.size(), now_seconds() - t_start);
  }
  if (pc.analytic) {
    // The reference against the analytic law on the first tick of every sequence (no friction
    // yet): how far the 0.25 mm reference itself is from the exact field.
    double err = 0.0, sum = 0.0;
    std::size_t tick_index = 0;
    for (const Sequence& seq : seqs) {
      const Vec3d f = pc.analytic(tool, seq.front());
      err += norm(ref_forces[tick_index] - f);
      sum += norm(f);
      tick_index += seq.size();
    }
    std::printf("  %s: reference vs analytic law on first ticks: %.4f %% of the force\n",
                pc.name.c_str(), 100.0 * err / sum);
  }
  double ref_sum = 0.0;
  for (const Vec3d& f : ref_forces) ref_sum += norm(f);

  std::vector<Result> results;
  for (double h : kResolutions) {
    Maps maps = pc.maps(h);
    const Vec3d offset = maps.offset - ref_offset;
    struct Entry {
      Result r;
      std::unique_ptr<Model> model;
      std::vector<double> times;
    };
    std::vector<Entry> entries;
    for (GradientScheme scheme : kSchemes)
      for (Storage storage : kStorages) {
        auto fields = std::make_shared<const FieldSampler>(maps.surf, maps.bone,
                                                           SamplerConfig{scheme, storage});
        Entry e;
        e.r = Result{pc.name, h, scheme, storage, 0,
                     0,       0, 0,      0,       static_cast<double>(fields->bytes_per_voxel())};
        e.model = std::make_unique<Model>(fields, tool);
        const std::vector<Vec3d> forces = run_forces(*e.model, seqs, offset);
        std::vector<double> err;
        double sum = 0.0, sq = 0.0;
        for (std::size_t i = 0; i < forces.size(); ++i) {
          const double d = norm(forces[i] - ref_forces[i]);
          err.push_back(d);
          sum += d;
          sq += d * d;
        }
        e.r.err_rel_pct = 100.0 * sum / ref_sum;
        e.r.err_mean = sum / static_cast<double>(err.size());
        e.r.err_rms = std::sqrt(sq / static_cast<double>(err.size()));
        e.r.err_p95 = percentile(err, 0.95);
        entries.push_back(std::move(e));
      }
    // Timing: repetitions interleaved over the configurations, the median kept.
    for (int rep = 0; rep < reps; ++rep)
      for (Entry& e : entries) time_ticks(*e.model, seqs, offset, e.times);
    for (Entry& e : entries) {
      e.r.tick_ns = median(e.times);
      results.push_back(e.r);
      std::printf("    %-34s %8.0f ns/tick  error %6.2f %%  (mean %.3f N, p95 %.3f N)\n",
                  config_name(e.r).c_str(), e.r.tick_ns, e.r.err_rel_pct, e.r.err_mean,
                  e.r.err_p95);
    }
  }
  mark_pareto(results);
  std::printf("  %s: %.1f s\n", pc.name.c_str(), now_seconds() - t_start);
  return results;
}

}  // namespace
}  // namespace palp::study

int main(int argc, char** argv) {
  using namespace palp;
  using namespace palp::study;
  bool torso = true;
  std::vector<char*> args{argv[0]};
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--no-torso") == 0)
      torso = false;
    else
      args.push_back(argv[i]);
  }
  const Flags flags = parse_flags(static_cast<int>(args.size()), args.data(),
                                  "study_speed_accuracy [--out DIR] [--quick] [--no-torso]");
  const int n_poses = flags.quick ? 40 : 200;
  const int reps = flags.quick ? 3 : 7;
  std::mt19937_64 rng(20240611);

  std::vector<PhantomCase> cases;
  cases.push_back({"sphere", sphere_maps, sphere_poses, sphere_analytic});
  if (torso) cases.push_back({"torso", torso_maps, torso_poses, nullptr});

  Csv csv(flags.out_dir + "/speed_accuracy.csv",
          {"phantom", "resolution_mm", "gradient", "storage", "config", "tick_ns", "err_rel_pct",
           "err_mean_N", "err_rms_N", "err_p95_N", "bytes_per_voxel", "pareto"});
  std::printf("speed_accuracy: finger:37, %d poses x %d ticks, timing median of %d\n", n_poses,
              kSlideTicks, reps);
  for (const PhantomCase& pc : cases) {
    std::vector<Result> rs = run_study(pc, n_poses, reps, rng);
    std::printf("  %s Pareto front (tick time vs force error):\n", pc.name.c_str());
    std::vector<const Result*> front;
    for (const Result& r : rs)
      if (r.pareto) front.push_back(&r);
    std::sort(front.begin(), front.end(),
              [](const Result* a, const Result* b) { return a->tick_ns < b->tick_ns; });
    for (const Result* r : front)
      std::printf("    %-34s %8.0f ns  %6.2f %%\n", config_name(*r).c_str(), r->tick_ns,
                  r->err_rel_pct);
    for (const Result& r : rs) {
      csv.row({r.phantom, r.h, std::string(to_string(r.scheme)), std::string(to_string(r.storage)),
               std::string(to_string(r.scheme)) + "/" + to_string(r.storage), r.tick_ns,
               r.err_rel_pct, r.err_mean, r.err_rms, r.err_p95, r.bytes_per_voxel,
               r.pareto ? 1.0 : 0.0});
    }
  }
  std::printf("wrote %s\n", csv.path().c_str());
  return 0;
}
