// Recording files: see recording.hpp for the format.
#include "rt/recording.hpp"

#include <fcntl.h>
#include <unistd.h>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "base/errors.hpp"
#include "io/gzip.hpp"
#include "scene/trajectory.hpp"

namespace palp::rt {
namespace {

static_assert(std::endian::native == std::endian::little,
              "recordings are little-endian; a big-endian port must swap bytes here");
static_assert(sizeof(double) == 8);

template <class T>
void put(unsigned char*& out, T value) {
  std::memcpy(out, &value, sizeof value);
  out += sizeof value;
}
template <class T>
T get(const unsigned char*& in) {
  T value;
  std::memcpy(&value, in, sizeof value);
  in += sizeof value;
  return value;
}

void put_vec(unsigned char*& out, const Vec3d& v) {
  put(out, v.x), put(out, v.y), put(out, v.z);
}
Vec3d get_vec(const unsigned char*& in) {
  Vec3d v;
  v.x = get<double>(in), v.y = get<double>(in), v.z = get<double>(in);
  return v;
}

std::string format_metadata(const RecordingMetadata& metadata) {
  std::string text;
  for (const auto& [key, value] : metadata) {
    if (key.find_first_of("=\n") != std::string::npos || value.find('\n') != std::string::npos)
      throw UsageError("recording metadata '" + key + "' may not contain '=' or newlines");
    text += key + "=" + value + "\n";
  }
  return text;
}

}  // namespace

void encode_record(const TickRecord& r, unsigned char* out) {
  unsigned char* p = out;
  put(p, r.seq);
  put(p, r.t_ns);
  put_vec(p, r.pose.position);
  put(p, r.pose.orientation.w), put(p, r.pose.orientation.x), put(p, r.pose.orientation.y),
      put(p, r.pose.orientation.z);
  put_vec(p, r.force);
  put_vec(p, r.torque);
  put_vec(p, r.u);
  put(p, r.n_contact);
  put(p, r.tick_status);
  put(p, r.safety_status);
  put(p, r.fault);
  put(p, r.late_ns);
}

TickRecord decode_record(const unsigned char* in) {
  const unsigned char* p = in;
  TickRecord r;
  r.seq = get<std::uint64_t>(p);
  r.t_ns = get<std::int64_t>(p);
  r.pose.position = get_vec(p);
  r.pose.orientation.w = get<double>(p);
  r.pose.orientation.x = get<double>(p);
  r.pose.orientation.y = get<double>(p);
  r.pose.orientation.z = get<double>(p);
  r.force = get_vec(p);
  r.torque = get_vec(p);
  r.u = get_vec(p);
  r.n_contact = get<std::int32_t>(p);
  r.tick_status = get<std::uint32_t>(p);
  r.safety_status = get<std::uint32_t>(p);
  r.fault = get<std::uint32_t>(p);
  r.late_ns = get<std::int64_t>(p);
  return r;
}

Recording read_recording(const std::string& path) {
  require_regular_file(path);  // a FIFO or a device would never end
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the recording");
  const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (in.bad()) throw InputError(path + ": cannot read the recording");
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() < 20 || std::memcmp(data, kRecordingMagic, 8) != 0)
    throw InputError(path + ": not a palpd recording (no PALPREC1 header)");
  const unsigned char* p = data + 8;
  const auto version = get<std::uint32_t>(p);
  const auto record_bytes = get<std::uint32_t>(p);
  const auto meta_len = get<std::uint32_t>(p);
  if (version != kRecordingVersion)
    throw InputError(path + ": recording format version " + std::to_string(version) +
                     " is not supported (expected " + std::to_string(kRecordingVersion) + ")");
  if (record_bytes != kRecordBytes)
    throw InputError(path + ": record size " + std::to_string(record_bytes) + " (expected " +
                     std::to_string(kRecordBytes) + ")");
  if (meta_len > bytes.size() - 20) throw InputError(path + ": metadata runs past the end");
  Recording rec;
  const std::string meta = bytes.substr(20, meta_len);
  std::size_t start = 0;
  while (start < meta.size()) {
    std::size_t end = meta.find('\n', start);
    if (end == std::string::npos) end = meta.size();
    const std::string line = meta.substr(start, end - start);
    const auto eq = line.find('=');
    if (!line.empty()) {
      if (eq == std::string::npos) throw InputError(path + ": bad metadata line '" + line + "'");
      rec.metadata[line.substr(0, eq)] = line.substr(eq + 1);
    }
    start = end + 1;
  }
  const std::size_t body = bytes.size() - 20 - meta_len;
  const std::size_t n = body / kRecordBytes;
  rec.truncated = body % kRecordBytes != 0;
  rec.records.reserve(n);
  for (std::size_t i = 0; i < n; ++i)
    rec.records.push_back(decode_record(data + 20 + meta_len + i * kRecordBytes));
  return rec;
}

std::string csv_path_for(const std::string& path) {
  std::filesystem::path p(path);
  if (p.extension() == ".csv") return path + ".csv";
  return p.replace_extension(".csv").string();
}

void append_recording_csv_row(std::string& out, const TickRecord& r, std::int64_t t0_ns) {
  const auto num = [&out](double v) {
    append_number(out, v);
    out += ',';
  };
  const auto integer = [&out](auto v) {
    out += std::to_string(v);
    out += ',';
  };
  num(static_cast<double>(r.t_ns - t0_ns) * 1e-9);
  num(r.force.x), num(r.force.y), num(r.force.z);
  num(r.torque.x), num(r.torque.y), num(r.torque.z);
  integer(r.n_contact);
  num(r.u.x), num(r.u.y), num(r.u.z);
  integer(r.seq);
  num(r.pose.position.x), num(r.pose.position.y), num(r.pose.position.z);
  num(r.pose.orientation.w), num(r.pose.orientation.x), num(r.pose.orientation.y),
      num(r.pose.orientation.z);
  integer(r.tick_status), integer(r.safety_status), integer(r.fault);
  append_number(out, static_cast<double>(r.late_ns) * 1e-3);
  out += '\n';
}

namespace {

// A new file, never an existing one and never through a symlink (O_EXCL | O_NOFOLLOW): a
// recording never overwrites anything.
std::FILE* create_exclusive(const std::string& path, const char* what) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int error = errno;
    if (error == EEXIST)
      throw Error(path + ": already exists; " + what +
                  " is never written over an existing file: choose another name");
    if (error == ELOOP) throw Error(path + ": is a symbolic link; " + what + " is not created");
    throw Error(path + ": cannot create " + what + ": " + std::strerror(error));
  }
  std::FILE* file = ::fdopen(fd, "wb");
  if (!file) {
    ::close(fd);
    throw Error(path + ": cannot create " + what);
  }
  return file;
}

}  // namespace

RecordingWriter::RecordingWriter(std::string path, const RecordingMetadata& metadata, bool csv)
    : path_(std::move(path)) {
  const std::string meta = format_metadata(metadata);
  file_ = create_exclusive(path_, "the recording");
  unsigned char header[20];
  unsigned char* p = header;
  std::memcpy(p, kRecordingMagic, 8);
  p += 8;
  put(p, kRecordingVersion);
  put(p, static_cast<std::uint32_t>(kRecordBytes));
  put(p, static_cast<std::uint32_t>(meta.size()));
  if (std::fwrite(header, 1, sizeof header, file_) != sizeof header ||
      std::fwrite(meta.data(), 1, meta.size(), file_) != meta.size())
    failed_ = true;
  if (csv) {
    csv_path_ = csv_path_for(path_);
    try {
      csv_ = create_exclusive(csv_path_, "the recording's CSV export");
    } catch (...) {
      std::fclose(file_);
      file_ = nullptr;
      std::remove(path_.c_str());  // ours, just created: leave no half recording behind
      throw;
    }
    csv_buffer_ = std::string(kRecordingCsvHeader) + "\n";
  }
}

RecordingWriter::~RecordingWriter() {
  if (file_) std::fclose(file_);
  if (csv_) std::fclose(csv_);
}

void RecordingWriter::write(const TickRecord& record) {
  unsigned char bytes[kRecordBytes];
  encode_record(record, bytes);
  if (!file_ || std::fwrite(bytes, 1, sizeof bytes, file_) != sizeof bytes) failed_ = true;
  if (count_ == 0) t0_ns_ = record.t_ns;
  ++count_;
  if (csv_) {
    append_recording_csv_row(csv_buffer_, record, t0_ns_);
    if (csv_buffer_.size() > (1u << 16)) {
      if (std::fwrite(csv_buffer_.data(), 1, csv_buffer_.size(), csv_) != csv_buffer_.size())
        failed_ = true;
      csv_buffer_.clear();
    }
  }
}

void RecordingWriter::finish() {
  if (csv_) {
    if (std::fwrite(csv_buffer_.data(), 1, csv_buffer_.size(), csv_) != csv_buffer_.size())
      failed_ = true;
    csv_buffer_.clear();
    if (std::fclose(csv_) != 0) failed_ = true;
    csv_ = nullptr;
  }
  if (file_) {
    if (std::fclose(file_) != 0) failed_ = true;
    file_ = nullptr;
  }
  if (failed_) throw Error(path_ + ": writing the recording failed");
}

Recorder::Recorder(SnapshotRing& ring, std::string path, const RecordingMetadata& metadata,
                   std::uint64_t first_seq)
    : ring_(ring), path_(path), writer_(std::move(path), metadata), first_seq_(first_seq) {
  thread_ = std::thread([this] {
    while (!stop_.load(std::memory_order_acquire)) {
      drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    drain();
  });
}

Recorder::~Recorder() {
  try {
    stop();
  } catch (const std::exception&) {
    // Destruction cannot report; stop() reports to callers that ask.
  }
}

void Recorder::drain() {
  while (const Snapshot* s = ring_.front()) {
    if (s->tick.seq >= first_seq_) {
      if (!any_recorded_) {
        any_recorded_ = true;
        first_rec_seq_ = s->tick.seq;
        first_rec_t_ns_ = s->tick.t_ns;
      }
      writer_.write(s->tick);
      count_.fetch_add(1, std::memory_order_relaxed);
    }
    ring_.pop();
  }
}

void Recorder::stop() {
  if (stopped_) return;
  stopped_ = true;
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
  writer_.finish();
}

std::string marks_path_for(const std::string& recording_path) {
  std::filesystem::path p(recording_path);
  return p.replace_extension(".marks.csv").string();
}

void write_recording_marks(const std::string& path, const std::vector<RecordedMark>& marks) {
  std::FILE* file = create_exclusive(path, "the recording's marks");
  std::string text = "t,tick\n";
  for (const RecordedMark& m : marks) {
    append_number(text, m.t);
    text += ',' + std::to_string(m.tick) + '\n';
  }
  const bool ok = std::fwrite(text.data(), 1, text.size(), file) == text.size();
  if (std::fclose(file) != 0 || !ok) throw Error(path + ": writing the recording's marks failed");
}

std::vector<RecordedMark> read_recording_marks(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot read the recording's marks");
  std::string line;
  if (!std::getline(in, line) || line.rfind("t,tick", 0) != 0)
    throw InputError(path + ": not a marks file (its header must start with t,tick)");
  std::vector<RecordedMark> marks;
  for (int row = 2; std::getline(in, line); ++row) {
    if (line.empty()) continue;
    if (marks.size() == kMaxRecordedMarks)
      throw InputError(path + ": more than " + std::to_string(kMaxRecordedMarks) + " marks");
    RecordedMark m;
    char* end = nullptr;
    m.t = std::strtod(line.c_str(), &end);
    const char* tick = end;
    if (*tick != ',' || !std::isfinite(m.t) || m.t < 0)
      throw InputError(path + " row " + std::to_string(row) + ": not t,tick");
    m.tick = std::strtoull(tick + 1, &end, 10);
    if (end == tick + 1 || (*end != '\0' && *end != ',' && *end != '\r'))
      throw InputError(path + " row " + std::to_string(row) + ": not t,tick");
    marks.push_back(m);
  }
  return marks;
}

}  // namespace palp::rt
