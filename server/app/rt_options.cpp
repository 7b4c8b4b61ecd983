#include "app/rt_options.hpp"

#include <cmath>
#include <cstdio>

#include "base/errors.hpp"
#include "loop/wake.hpp"

namespace palp::app {
namespace {

int cpu_option(const cli::Args& args, const std::string& key) {
  const double v = args.number(key, -1);
  if (v == -1 && !args.get(key)) return -1;
  if (!(v >= 0 && v < 1024) || v != std::floor(v))
    throw UsageError("--" + key + " must be a CPU number (this machine allows " +
                     rt::allowed_cpus_text() + ")");
  const int cpu = static_cast<int>(v);
  if (!rt::cpu_allowed(cpu))
    throw UsageError("--" + key + " " + std::to_string(cpu) + ": not a CPU palpd may use (" +
                     rt::allowed_cpus_text() + ")");
  return cpu;
}

}  // namespace

std::vector<std::string> with_rt_options(std::vector<std::string> valued) {
  valued.insert(valued.end(), kRtValued.begin(), kRtValued.end());
  return valued;
}

void apply_rt_options(const cli::Args& args, rt::LoopConfig& loop, net::ServerConfig& server) {
  loop.wake.mode = rt::parse_wake_mode(args.get("wake").value_or("hybrid"));
  const double spin = args.number("spin-us", 0.0);
  if (!(spin >= 0 && spin <= 1e6)) throw UsageError("--spin-us must be in [0, 1000000]");
  if (spin > 0 && loop.wake.mode != rt::WakeMode::Hybrid)
    throw UsageError("--spin-us applies to --wake hybrid only");
  loop.wake.spin_us = spin;
  server.net_wake = net::parse_net_wake(args.get("net-wake").value_or("event"));
  loop.cpu = cpu_option(args, "rt-cpu");
  server.cpu = cpu_option(args, "net-cpu");
  if (loop.cpu >= 0 && loop.cpu == server.cpu)
    throw UsageError("--net-cpu must differ from --rt-cpu (the loop keeps its CPU to itself)");
  if (loop.cpu >= 0) {
    const std::string failure = rt::keep_this_thread_off(loop.cpu);
    if (!failure.empty()) std::fprintf(stderr, "palpd: warning: %s\n", failure.c_str());
  }
}

}  // namespace palp::app
