// Trajectory and force files of offline runs (spec "Files").
//
// Trajectory CSV: the header row `t,px,py,pz,qw,qx,qy,qz`, then one row per tick: time (s),
// device point (mm, scene frame) and the unit quaternion (w, x, y, z) mapping tool to scene frame.
// Reading is strict: the exact header, exactly 8 numbers a row, finite values, times strictly
// increasing, quaternions within kQuatNormTolerance of unit length (then normalised). Errors name
// the file and line: "FILE:LINE: message". "\r\n" line ends are accepted.
//
// Force CSV: the header starts `t,fx,fy,fz,tx,ty,tz,n_contact,ux,uy,uz` (the spec's columns, in
// N, N·mm, mm), followed by f_normal, f_lateral, depth, status, safety (see ForceRecord).
//
// Numbers are written in the shortest form that reads back to the same double (std::to_chars),
// so equal runs give byte-identical files and a written trajectory reads back bit for bit.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "base/vec.hpp"
#include "model/force_model.hpp"

namespace palp {

struct TrajectorySample {
  double t = 0.0;  // s
  Pose pose;       // device point (mm) and orientation, scene frame
};
using Trajectory = std::vector<TrajectorySample>;

inline constexpr const char* kTrajectoryHeader = "t,px,py,pz,qw,qx,qy,qz";
inline constexpr const char* kForceHeader =
    "t,fx,fy,fz,tx,ty,tz,n_contact,ux,uy,uz,f_normal,f_lateral,depth,status,safety";
// A quaternion whose norm is off 1 by more than this is refused (a column mix-up, not rounding).
inline constexpr double kQuatNormTolerance = 1e-3;

// Parses trajectory CSV text; `name` prefixes error messages. InputError on any defect.
Trajectory parse_trajectory_csv(std::string_view text, const std::string& name);
// Reads a trajectory CSV file (InputError when missing, unreadable or malformed).
Trajectory read_trajectory_csv(const std::string& path);

// The CSV text of a trajectory (header and one row per sample).
std::string format_trajectory_csv(const Trajectory& trajectory);
// Writes it under a temporary name and renames (Error when it cannot be written).
void write_trajectory_csv(const std::string& path, const Trajectory& trajectory);

// One row of the force CSV: the device output of a tick and a summary of its contacts.
struct ForceRecord {
  double t = 0.0;            // s, the trajectory row's time
  Vec3d force{};             // N, device force (after the safety filters when a profile is applied)
  Vec3d torque{};            // N·mm, about the device point (likewise)
  int n_contact = 0;         // points in contact
  Vec3d u{};                 // mm, mean of p - x over the points in contact
  double f_normal{};         // N, mean over contacts of (f - f_friction) . v_s: the pressing force
  double f_lateral{};        // N, mean over contacts of |f_friction| in the skin's tangent plane
  double depth{};            // mm, mean D_surf over contacts
  std::uint32_t status = 0;  // TickStatus bits of the tick
  std::uint32_t safety = 0;  // SafetyStatus bits of the filters (0 when none applied)
};

// The record of the tick that left `state` (force, torque unfiltered; safety = 0).
ForceRecord force_record(double t, const State& state);

// Appends one CSV row (with '\n') for `record` to `out`.
void append_force_csv_row(std::string& out, const ForceRecord& record);

// Streams force rows to a file: the header at open, rows as they come, and the file renamed into
// place by finish(); a writer destroyed without finish() removes its partial file.
class ForceCsvWriter {
 public:
  explicit ForceCsvWriter(std::string path);
  ~ForceCsvWriter();
  ForceCsvWriter(const ForceCsvWriter&) = delete;
  ForceCsvWriter& operator=(const ForceCsvWriter&) = delete;

  void write(const ForceRecord& record);
  void finish();  // Error when the file cannot be completed

 private:
  void flush_buffer();
  std::string path_, partial_path_;
  std::FILE* file_ = nullptr;
  std::string buffer_;
};

// Appends the shortest round-trip decimal form of `value` (-0 written as 0).
void append_number(std::string& out, double value);
// The same as a string.
std::string number_text(double value);

}  // namespace palp
