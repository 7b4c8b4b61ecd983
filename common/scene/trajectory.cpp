// Trajectory CSV reading and writing, and the force CSV of offline runs (see trajectory.hpp).
#include "scene/trajectory.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <system_error>
#include <utility>

#include "base/errors.hpp"
#include "base/file_replace.hpp"
#include "io/gzip.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kTrajectoryColumns = 8;
constexpr std::array<const char*, kTrajectoryColumns> kTrajectoryColumnNames = {
    "t", "px", "py", "pz", "qw", "qx", "qy", "qz"};
constexpr std::size_t kWriterFlushBytes = 1 << 20;

// "FILE:LINE: message"
InputError line_error(const std::string& name, std::size_t line, const std::string& message) {
  return InputError(name + ":" + std::to_string(line) + ": " + message);
}

std::string_view strip_cr(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

// Splits `line` at commas into exactly kTrajectoryColumns fields, or reports the count found.
bool split_fields(std::string_view line, std::array<std::string_view, kTrajectoryColumns>& fields,
                  std::size_t* count) {
  std::size_t n = 0;
  while (true) {
    const std::size_t comma = line.find(',');
    if (n < kTrajectoryColumns) fields[n] = line.substr(0, comma);
    ++n;
    if (comma == std::string_view::npos) break;
    line.remove_prefix(comma + 1);
  }
  *count = n;
  return n == kTrajectoryColumns;
}

// One finite number filling the whole field, or an error naming the column.
double parse_field(std::string_view field, std::size_t column, const std::string& name,
                   std::size_t line) {
  double value = 0.0;
  const char* begin = field.data();
  const char* end = field.data() + field.size();
  const auto [stop, ec] = std::from_chars(begin, end, value);
  if (field.empty() || ec != std::errc() || stop != end) {
    throw line_error(name, line,
                     std::string("column ") + kTrajectoryColumnNames[column] + ": '" +
                         std::string(field) + "' is not a number");
  }
  if (!std::isfinite(value)) {
    throw line_error(name, line,
                     std::string("column ") + kTrajectoryColumnNames[column] + ": '" +
                         std::string(field) + "' is not finite");
  }
  return value;
}

// A data row -> sample; quaternion checked for unit length and normalised.
TrajectorySample parse_row(std::string_view line, const std::string& name, std::size_t number) {
  std::array<std::string_view, kTrajectoryColumns> fields;
  std::size_t count = 0;
  if (!split_fields(line, fields, &count)) {
    throw line_error(name, number,
                     "expected " + std::to_string(kTrajectoryColumns) + " values (" +
                         kTrajectoryHeader + "), got " + std::to_string(count));
  }
  std::array<double, kTrajectoryColumns> v{};
  for (std::size_t c = 0; c < kTrajectoryColumns; ++c)
    v[c] = parse_field(fields[c], c, name, number);
  const Quat q{v[4], v[5], v[6], v[7]};
  const double qn = norm(q);
  if (!(std::fabs(qn - 1.0) <= kQuatNormTolerance)) {
    char text[96];
    std::snprintf(text, sizeof text, "quaternion (qw,qx,qy,qz) has norm %.6g, not 1", qn);
    throw line_error(name, number, text);
  }
  return {v[0], Pose{{v[1], v[2], v[3]}, normalized(q)}};
}

void append_separator(std::string& out) {
  out.push_back(',');
}

void append_vec(std::string& out, const Vec3d& v) {
  append_number(out, v.x);
  append_separator(out);
  append_number(out, v.y);
  append_separator(out);
  append_number(out, v.z);
}

void append_unsigned(std::string& out, std::uint64_t value) {
  char text[24];
  const auto [end, ec] = std::to_chars(text, text + sizeof text, value);
  out.append(text, end);
}

}  // namespace

void append_number(std::string& out, double value) {
  char text[32];
  const auto [end, ec] = std::to_chars(text, text + sizeof text, value + 0.0);  // -0 -> 0
  out.append(text, end);
}

std::string number_text(double value) {
  std::string s;
  append_number(s, value);
  return s;
}

Trajectory parse_trajectory_csv(std::string_view text, const std::string& name) {
  Trajectory out;
  std::size_t number = 0;
  while (!text.empty()) {
    const std::size_t newline = text.find('\n');
    const std::string_view line = strip_cr(text.substr(0, newline));
    text.remove_prefix(newline == std::string_view::npos ? text.size() : newline + 1);
    ++number;
    if (number == 1) {
      if (line != kTrajectoryHeader) {
        throw line_error(name, number,
                         std::string("expected the header '") + kTrajectoryHeader + "', got '" +
                             std::string(line.substr(0, 80)) + "'");
      }
      continue;
    }
    if (line.empty()) throw line_error(name, number, "empty line");
    const TrajectorySample sample = parse_row(line, name, number);
    if (!out.empty() && !(sample.t > out.back().t)) {
      throw line_error(name, number, "t must increase from row to row");
    }
    out.push_back(sample);
  }
  if (number == 0)
    throw InputError(name + ": empty file (expected the header " + std::string(kTrajectoryHeader) +
                     ")");
  if (out.empty()) throw InputError(name + ": no trajectory rows after the header");
  return out;
}

Trajectory read_trajectory_csv(const std::string& path) {
  require_regular_file(path);  // a FIFO or a device would never end
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot be read");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path + ": cannot be read");
  return parse_trajectory_csv(text, path);
}

std::string format_trajectory_csv(const Trajectory& trajectory) {
  std::string out = kTrajectoryHeader;
  out.push_back('\n');
  out.reserve(out.size() + trajectory.size() * 160);
  for (const TrajectorySample& s : trajectory) {
    const Quat& q = s.pose.orientation;
    append_number(out, s.t);
    append_separator(out);
    append_vec(out, s.pose.position);
    for (double c : {q.w, q.x, q.y, q.z}) {
      append_separator(out);
      append_number(out, c);
    }
    out.push_back('\n');
  }
  return out;
}

void write_trajectory_csv(const std::string& path, const Trajectory& trajectory) {
  replace_file(path, format_trajectory_csv(trajectory));
}

ForceRecord force_record(double t, const State& state) {
  ForceRecord r;
  r.t = t;
  r.force = state.f_device;
  r.torque = state.tau_device;
  r.n_contact = state.n_contact;
  r.u = state.u;
  r.status = state.status;
  // Contact summary: the skin normal of point i is v_s = (s - x) / depth.
  double normal_sum = 0.0, lateral_sum = 0.0, depth_sum = 0.0;
  for (std::size_t i = 0; i < state.in_contact.size(); ++i) {
    if (!state.in_contact[i]) continue;
    const Vec3d offset = state.s[i] - state.x[i];
    const double length = norm(offset);
    const Vec3d v_s = length > 0.0 ? offset * (1.0 / length) : Vec3d{};
    const Vec3d& friction = state.f_friction[i];
    normal_sum += dot(state.f[i] - friction, v_s);
    lateral_sum += norm(friction - dot(friction, v_s) * v_s);
    depth_sum += state.depth[i];
  }
  if (state.n_contact > 0) {
    const double inv = 1.0 / state.n_contact;
    r.f_normal = normal_sum * inv;
    r.f_lateral = lateral_sum * inv;
    r.depth = depth_sum * inv;
  }
  return r;
}

void append_force_csv_row(std::string& out, const ForceRecord& r) {
  append_number(out, r.t);
  append_separator(out);
  append_vec(out, r.force);
  append_separator(out);
  append_vec(out, r.torque);
  append_separator(out);
  append_unsigned(out, static_cast<std::uint64_t>(r.n_contact));
  append_separator(out);
  append_vec(out, r.u);
  for (double v : {r.f_normal, r.f_lateral, r.depth}) {
    append_separator(out);
    append_number(out, v);
  }
  append_separator(out);
  append_unsigned(out, r.status);
  append_separator(out);
  append_unsigned(out, r.safety);
  out.push_back('\n');
}

ForceCsvWriter::ForceCsvWriter(std::string path)
    : path_(std::move(path)), partial_path_(path_ + ".partial") {
  file_ = std::fopen(partial_path_.c_str(), "wb");
  if (!file_) throw Error(path_ + ": cannot be written");
  buffer_.reserve(kWriterFlushBytes + 512);
  buffer_ = kForceHeader;
  buffer_.push_back('\n');
}

ForceCsvWriter::~ForceCsvWriter() {
  if (!file_) return;
  std::fclose(file_);
  std::error_code ec;
  fs::remove(partial_path_, ec);
}

void ForceCsvWriter::write(const ForceRecord& record) {
  append_force_csv_row(buffer_, record);
  if (buffer_.size() >= kWriterFlushBytes) flush_buffer();
}

void ForceCsvWriter::flush_buffer() {
  if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
    throw Error(path_ + ": cannot be written");
  buffer_.clear();
}

void ForceCsvWriter::finish() {
  if (!file_) throw Error(path_ + ": already finished");
  flush_buffer();
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  std::error_code ec;
  if (!closed) {
    fs::remove(partial_path_, ec);
    throw Error(path_ + ": cannot be written");
  }
  fs::rename(partial_path_, path_, ec);
  if (ec) throw Error(path_ + ": cannot be written: " + ec.message());
}

}  // namespace palp
