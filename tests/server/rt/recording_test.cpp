// Recording files: the binary layout, round trips, damaged files, the CSV export, the Recorder.
#include "rt/recording.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "base/errors.hpp"

namespace palp::rt {
namespace {

namespace fs = std::filesystem;

// Emptied on first use: a leftover of an earlier process with the same pid would make the
// recorder's exclusive create refuse (recordings are never written over).
fs::path temp_dir() {
  static const fs::path dir = [] {
    const fs::path d = fs::temp_directory_path() / ("palp-recording-" + std::to_string(::getpid()));
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

TickRecord sample_record(std::uint64_t i) {
  TickRecord r;
  r.seq = i;
  r.t_ns = 1'000'000'000 + std::int64_t(i) * 1'000'000;
  r.pose.position = {1.0 + double(i), -2.5, 0.1 * double(i)};
  r.pose.orientation = {0.5, 0.5, -0.5, 0.5};
  r.force = {0.1 / 3.0, -1e-300, 7.0};
  r.torque = {-3.0, 0.0, 1.0 / 7.0};
  r.u = {1e-17, 2.0, -0.0};
  r.n_contact = int(i % 37);
  r.tick_status = 5;
  r.safety_status = 6;
  r.fault = i == 3 ? 1u : 0u;
  r.late_ns = 12345;
  return r;
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(Recording, RecordLayoutIsDocumented) {
  const TickRecord r = sample_record(7);
  unsigned char bytes[kRecordBytes];
  encode_record(r, bytes);
  std::uint64_t seq;
  std::memcpy(&seq, bytes, 8);
  EXPECT_EQ(seq, 7u);
  double px, fz;
  std::memcpy(&px, bytes + 16, 8);
  std::memcpy(&fz, bytes + 16 + 7 * 8 + 2 * 8, 8);
  EXPECT_EQ(px, 8.0);
  EXPECT_EQ(fz, 7.0);
  std::int64_t late;
  std::memcpy(&late, bytes + 160, 8);
  EXPECT_EQ(late, 12345);
  EXPECT_EQ(decode_record(bytes), r);
}

TEST(Recording, WritesAndReadsBackBitForBit) {
  const fs::path path = temp_dir() / "session.palprec";
  {
    RecordingWriter w(path.string(), {{"scene", "phantom:sphere"}, {"tool", "finger:7"}});
    for (std::uint64_t i = 0; i < 10; ++i) w.write(sample_record(i));
    w.finish();
    EXPECT_EQ(w.count(), 10u);
  }
  const Recording rec = read_recording(path.string());
  EXPECT_FALSE(rec.truncated);
  EXPECT_EQ(rec.metadata.at("scene"), "phantom:sphere");
  EXPECT_EQ(rec.metadata.at("tool"), "finger:7");
  ASSERT_EQ(rec.records.size(), 10u);
  for (std::uint64_t i = 0; i < 10; ++i) EXPECT_EQ(rec.records[i], sample_record(i));
  // Header: magic, version, record size.
  const std::string bytes = read_all(path);
  EXPECT_EQ(bytes.substr(0, 8), "PALPREC1");
  const std::string csv = read_all(csv_path_for(path.string()));
  EXPECT_EQ(csv.substr(0, csv.find('\n')), kRecordingCsvHeader);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 11);
  // First row: t = 0, force, torque, n_contact 0, u, seq 0.
  const std::string row =
      csv.substr(csv.find('\n') + 1, csv.find('\n', csv.find('\n') + 1) - csv.find('\n') - 1);
  EXPECT_EQ(row.substr(0, 2), "0,");
  EXPECT_NE(row.find("0.03333333333333333,-1e-300,7,-3,0,0.14285714285714285,0,"),
            std::string::npos)
      << row;
}

TEST(Recording, CutFileLosesOnlyTheLastRecord) {
  const fs::path path = temp_dir() / "cut.palprec";
  {
    RecordingWriter w(path.string(), {}, false);
    for (std::uint64_t i = 0; i < 3; ++i) w.write(sample_record(i));
    w.finish();
  }
  fs::resize_file(path, fs::file_size(path) - 5);
  const Recording rec = read_recording(path.string());
  EXPECT_TRUE(rec.truncated);
  EXPECT_EQ(rec.records.size(), 2u);
}

TEST(Recording, RejectsOtherFiles) {
  const fs::path dir = temp_dir();
  EXPECT_THROW(read_recording((dir / "missing.palprec").string()), InputError);
  std::ofstream(dir / "text.palprec") << "t,px,py,pz\n";
  EXPECT_THROW(read_recording((dir / "text.palprec").string()), InputError);
  std::string header(20, '\0');
  std::memcpy(header.data(), "PALPREC1", 8);
  header[8] = 2;  // version 2
  std::ofstream(dir / "v2.palprec", std::ios::binary) << header;
  EXPECT_THROW(read_recording((dir / "v2.palprec").string()), InputError);
  header[8] = 1;
  header[12] = 100;  // record size 100
  std::ofstream(dir / "size.palprec", std::ios::binary) << header;
  EXPECT_THROW(read_recording((dir / "size.palprec").string()), InputError);
  header[12] = static_cast<char>(kRecordBytes);
  header[16] = 50;  // metadata longer than the file
  std::ofstream(dir / "meta.palprec", std::ios::binary) << header;
  EXPECT_THROW(read_recording((dir / "meta.palprec").string()), InputError);
}

// A recording is created, never written over: an existing file, an existing CSV or a symlink in
// its place is refused, and nothing is left behind.
TEST(Recording, NeverOverwritesOrFollowsSymlinks) {
  const fs::path dir = temp_dir() / "exclusive";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path taken = dir / "taken.palprec";
  std::ofstream(taken) << "precious";
  try {
    RecordingWriter w(taken.string(), {});
    ADD_FAILURE() << "wrote over an existing file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("already exists"), std::string::npos) << e.what();
  }
  std::ifstream in(taken);
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "precious");

  const fs::path target = dir / "elsewhere.txt";
  std::ofstream(target) << "also precious";
  fs::create_symlink(target, dir / "link.palprec");
  EXPECT_THROW(RecordingWriter((dir / "link.palprec").string(), {}), Error);
  std::ifstream in2(target);
  std::getline(in2, text);
  EXPECT_EQ(text, "also precious");

  // The CSV's name is taken: the binary just created is removed again.
  std::ofstream(dir / "half.csv") << "x";
  EXPECT_THROW(RecordingWriter((dir / "half.palprec").string(), {}, true), Error);
  EXPECT_FALSE(fs::exists(dir / "half.palprec"));
}

TEST(Recording, CsvPathReplacesTheExtension) {
  EXPECT_EQ(csv_path_for("a/b.palprec"), "a/b.csv");
  EXPECT_EQ(csv_path_for("rec"), "rec.csv");
  EXPECT_EQ(csv_path_for("x.csv"), "x.csv.csv");
}

TEST(Recorder, DrainsTheRingFromItsFirstSeq) {
  SnapshotRing ring(64, 0);
  for (std::uint64_t i = 0; i < 3; ++i) {  // leftovers from before the recording
    ring.claim()->tick = sample_record(i);
    ring.commit();
  }
  const fs::path path = temp_dir() / "recorder.palprec";
  {
    Recorder recorder(ring, path.string(), {{"k", "v"}}, 3);
    for (std::uint64_t i = 3; i < 40; ++i) {
      while (!ring.claim()) std::this_thread::yield();
      ring.claim()->tick = sample_record(i);
      ring.commit();
    }
    recorder.stop();
    EXPECT_EQ(recorder.count(), 37u);
  }
  const Recording rec = read_recording(path.string());
  ASSERT_EQ(rec.records.size(), 37u);
  EXPECT_EQ(rec.records.front(), sample_record(3));
  EXPECT_EQ(rec.records.back(), sample_record(39));
}

}  // namespace
}  // namespace palp::rt
