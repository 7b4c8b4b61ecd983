// Recordings of palpd sessions: every tick's device-level outcome (TickRecord), written by a
// recorder thread that drains the loop's record ring, for replay and for charts.
//
// Binary file (all integers and doubles little-endian, IEEE 754):
//   offset 0   8 bytes  magic "PALPREC1"
//          8   u32      format version (1)
//         12   u32      record size in bytes (kRecordBytes = 168)
//         16   u32      metadata length M
//         20   M bytes  metadata: UTF-8 lines "key=value\n" (scene, tool, rate_hz, device,
//                       device_profile, params, ...)
//     20 + M   records, kRecordBytes each, in tick order:
//                u64 seq, i64 t_ns, f64 px py pz qw qx qy qz, f64 fx fy fz, f64 tx ty tz,
//                f64 ux uy uz, i32 n_contact, u32 tick_status, u32 safety_status, u32 fault,
//                i64 late_ns
//   A file cut in the middle of a record (a crash) reads back without that record.
// CSV export (written next to it, see csv_path_for): the offline force CSV's columns first,
//   t,fx,fy,fz,tx,ty,tz,n_contact,ux,uy,uz, then seq,px,py,pz,qw,qx,qy,qz,tick_status,
//   safety_status,fault,late_us; t in seconds since the first recorded tick, numbers in their
//   shortest round-trip form.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "rt/snapshot.hpp"

namespace palp::rt {

inline constexpr char kRecordingMagic[8] = {'P', 'A', 'L', 'P', 'R', 'E', 'C', '1'};
inline constexpr std::uint32_t kRecordingVersion = 1;
inline constexpr std::size_t kRecordBytes = 168;
inline constexpr const char* kRecordingCsvHeader =
    "t,fx,fy,fz,tx,ty,tz,n_contact,ux,uy,uz,seq,px,py,pz,qw,qx,qy,qz,tick_status,safety_status,"
    "fault,late_us";

using RecordingMetadata = std::map<std::string, std::string>;

struct Recording {
  RecordingMetadata metadata;
  std::vector<TickRecord> records;
  bool truncated = false;  // the file ended inside a record
};

// Encodes / decodes one record (kRecordBytes).
void encode_record(const TickRecord& record, unsigned char* out);
TickRecord decode_record(const unsigned char* in);

// Reads a recording; InputError naming the file for a missing file, a wrong magic, version or
// record size, or metadata that does not fit.
Recording read_recording(const std::string& path);

// FILE with its extension replaced by .csv (FILE.csv when it already ends in .csv).
std::string csv_path_for(const std::string& path);

// Appends one CSV row for `record`; t is relative to `t0_ns`.
void append_recording_csv_row(std::string& out, const TickRecord& record, std::int64_t t0_ns);

// Writes a recording file and its CSV export. Not real time (buffered stdio).
class RecordingWriter {
 public:
  // Error when the files cannot be created.
  RecordingWriter(std::string path, const RecordingMetadata& metadata, bool csv = true);
  ~RecordingWriter();
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  void write(const TickRecord& record);
  // Flushes and closes both files (Error when a write failed).
  void finish();
  std::uint64_t count() const { return count_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_, csv_path_;
  std::FILE* file_ = nullptr;
  std::FILE* csv_ = nullptr;
  std::string csv_buffer_;
  std::int64_t t0_ns_ = 0;
  std::uint64_t count_ = 0;
  bool failed_ = false;
};

// Drains a SnapshotRing into a RecordingWriter on its own thread.
class Recorder {
 public:
  // Records ticks with seq >= first_seq (older leftovers in the ring are discarded).
  Recorder(SnapshotRing& ring, std::string path, const RecordingMetadata& metadata,
           std::uint64_t first_seq = 0);
  ~Recorder();  // stop()
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Drains what is left, closes the files and joins. Error when the files could not be written.
  void stop();
  std::uint64_t count() const { return count_.load(std::memory_order_relaxed); }
  const std::string& path() const { return path_; }
  // After stop(): the first tick recorded (its seq and deadline), false when none was.
  bool first_recorded(std::uint64_t& seq, std::int64_t& t_ns) const {
    seq = first_rec_seq_;
    t_ns = first_rec_t_ns_;
    return any_recorded_;
  }

 private:
  void drain();
  SnapshotRing& ring_;
  std::string path_;
  RecordingWriter writer_;
  std::uint64_t first_seq_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> count_{0};
  std::string error_;
  std::thread thread_;
  bool stopped_ = false;
  // the recorder thread's, read after stop() joined it
  bool any_recorded_ = false;
  std::uint64_t first_rec_seq_ = 0;
  std::int64_t first_rec_t_ns_ = 0;
};

// The training marks taken while a recording ran (issue 40), in a CSV beside it, so its replay
// scores the same trials: FILE with its extension replaced by .marks.csv (rec/s1.palprec ->
// rec/s1.marks.csv; rec/s1 -> rec/s1.marks.csv). Header "t,tick", one mark a row: t in seconds
// since the recording's first tick (the recording CSV's t), tick the record's index from 0 (the
// tick a replay reaches it). The recording file itself is unchanged (older ones have no marks).
struct RecordedMark {
  double t = 0.0;
  std::uint64_t tick = 0;
};
inline constexpr std::size_t kMaxRecordedMarks = 100000;
std::string marks_path_for(const std::string& recording_path);
// Created exclusively (never over an existing file or link); Error when it cannot be written.
void write_recording_marks(const std::string& path, const std::vector<RecordedMark>& marks);
// InputError naming the file for a bad header or row, or more than kMaxRecordedMarks rows.
std::vector<RecordedMark> read_recording_marks(const std::string& path);

}  // namespace palp::rt
