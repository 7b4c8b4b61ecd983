// The frame pump: the io thread is woken by the loop's eventfd (or a poll timer) and takes every
// snapshot; idle, it sleeps (only the backstop timer runs).
#include "net/frame_pump.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "base/errors.hpp"

namespace palp::net {
namespace {

TEST(FramePump, ModesParseAndPrint) {
  EXPECT_EQ(parse_net_wake("event"), NetWake::Event);
  EXPECT_EQ(parse_net_wake("event-every"), NetWake::EventEvery);
  EXPECT_EQ(parse_net_wake("poll"), NetWake::Poll);
  EXPECT_STREQ(to_string(NetWake::EventEvery), "event-every");
  EXPECT_THROW(parse_net_wake("spin"), UsageError);
}

// A producer thread standing in for the loop publishes `count` snapshots, `gap` apart; the pump's
// callback drains them on the io thread.
struct PumpRun {
  std::uint64_t drained = 0, wakeups = 0, writes = 0;
  bool in_order = true;
};

PumpRun pump_snapshots(NetWake mode, std::uint64_t count, std::chrono::microseconds gap) {
  rt::SnapshotRing ring(1024, 0);
  rt::WakeSignal signal;
  asio::io_context io;
  PumpRun r;
  FramePump pump(io, ring, signal, mode, 0.0005, [&] {
    while (const rt::Snapshot* s = ring.front()) {
      r.in_order = r.in_order && s->tick.seq == r.drained;
      ++r.drained;
      ring.pop();
    }
    if (r.drained == count) io.stop();
  });
  pump.start();
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < count; ++i) {
      while (!ring.claim()) std::this_thread::yield();
      ring.claim()->tick.seq = i;
      ring.commit();
      signal.notify();
      std::this_thread::sleep_for(gap);
    }
  });
  asio::steady_timer guard(io);
  guard.expires_after(std::chrono::seconds(20));
  guard.async_wait([&](const asio::error_code& ec) {
    if (!ec) io.stop();
  });
  io.run();
  producer.join();
  r.wakeups = pump.wakeups();
  r.writes = signal.writes();
  return r;
}

TEST(FramePump, TheEventfdWakesTheIoThreadForEverySnapshot) {
  const PumpRun r = pump_snapshots(NetWake::Event, 2000, std::chrono::microseconds(50));
  EXPECT_EQ(r.drained, 2000u);
  EXPECT_TRUE(r.in_order);
  EXPECT_GT(r.writes, 0u);
  // coalesced: at most one write per wake-up the reader asked for (plus the one in flight)
  EXPECT_LE(r.writes, r.wakeups + 1);
}

TEST(FramePump, EveryModeWritesOncePerSnapshot) {
  const PumpRun r = pump_snapshots(NetWake::EventEvery, 500, std::chrono::microseconds(100));
  EXPECT_EQ(r.drained, 500u);
  EXPECT_EQ(r.writes, 500u);
}

TEST(FramePump, PollModeStillTakesEverySnapshot) {
  const PumpRun r = pump_snapshots(NetWake::Poll, 500, std::chrono::microseconds(100));
  EXPECT_EQ(r.drained, 500u);
  EXPECT_TRUE(r.in_order);
  EXPECT_EQ(r.writes, 0u);  // the loop never signals in poll mode
}

TEST(FramePump, AnIdleIoThreadSleepsButForTheBackstop) {
  rt::SnapshotRing ring(16, 0);
  rt::WakeSignal signal;
  asio::io_context io;
  std::uint64_t calls = 0;
  FramePump pump(io, ring, signal, NetWake::Event, 0.0005, [&] { ++calls; });
  pump.start();
  io.run_for(std::chrono::milliseconds(300));
  // the 20 ms backstop: about 15 in 300 ms (never more); a 500 us poll would have made 600
  EXPECT_LE(calls, 16u);
  EXPECT_EQ(signal.writes(), 0u);
  pump.stop();
}

}  // namespace
}  // namespace palp::net
