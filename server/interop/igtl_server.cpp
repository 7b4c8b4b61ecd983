#include "interop/igtl_server.hpp"

#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <cstring>
#include <ctime>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

#include "base/errors.hpp"
#include "igtlTransformMessage.h"
#include "interop/igtl_frame.hpp"
#include "loop/haptic_loop.hpp"

namespace palp::interop {
namespace {

using asio::ip::tcp;
using Bytes = std::shared_ptr<const std::vector<unsigned char>>;

// CLOCK_MONOTONIC tick time -> wall-clock seconds and nanoseconds for the message header.
void wall_time_of(std::int64_t t_ns, std::uint32_t& sec, std::uint32_t& nsec) {
  timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  const std::int64_t wall = static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec -
                            (rt::monotonic_ns() - t_ns);
  sec = static_cast<std::uint32_t>(wall / 1'000'000'000);
  nsec = static_cast<std::uint32_t>(wall % 1'000'000'000);
}

void append_transform(std::vector<unsigned char>& out, const std::string& name, const Matrix4& m,
                      std::uint32_t sec, std::uint32_t nsec) {
  igtl::TransformMessage::Pointer msg = igtl::TransformMessage::New();
  msg->SetDeviceName(name.c_str());
  igtl::Matrix4x4 f;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) f[r][c] = static_cast<float>(m[r][c]);
  msg->SetMatrix(f);
  igtl::TimeStamp::Pointer ts = igtl::TimeStamp::New();
  ts->SetTime(sec, nsec);
  msg->SetTimeStamp(ts);
  msg->Pack();
  const auto* p = static_cast<const unsigned char*>(msg->GetPackPointer());
  out.insert(out.end(), p, p + msg->GetPackSize());
}

Matrix4 translation(const Vec3d& v) {
  Matrix4 m{};
  for (int i = 0; i < 4; ++i) m[i][i] = 1.0;
  m[0][3] = v.x, m[1][3] = v.y, m[2][3] = v.z;
  return m;
}

}  // namespace

class IgtlServer::Impl {
  // One tick's tool state as the loop hands it over (a member type: the class is not in this
  // file's anonymous namespace).
  struct Sample {
    std::int64_t t_ns = 0;
    Pose pose{};
    Vec3d force{}, u{};
  };

 public:
  Impl(IgtlConfig config, const Grid& grid)
      : config_(std::move(config)), frame_(ras_from_scene(grid)), acceptor_(io_) {
    if (!(config_.rate_hz > 0.0)) throw UsageError("--igtl-rate must be positive");
    interval_ns_ = static_cast<std::int64_t>(1e9 / config_.rate_hz);
    asio::error_code ec;
    const asio::ip::address address = asio::ip::make_address(config_.bind, ec);
    if (ec) throw UsageError("--bind '" + config_.bind + "' is not an IP address");
    const tcp::endpoint endpoint(address, config_.port);
    acceptor_.open(endpoint.protocol(), ec);
    if (!ec) acceptor_.set_option(tcp::acceptor::reuse_address(true), ec);
    if (!ec) acceptor_.bind(endpoint, ec);
    if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
      throw ResourceError("OpenIGTLink: cannot listen on " + config_.bind + ":" +
                          std::to_string(config_.port) + ": " + ec.message() +
                          " (choose another --igtl-port, or 0 for any free port)");
  }

  ~Impl() { stop(); }

  std::uint16_t port() const { return acceptor_.local_endpoint().port(); }
  const IgtlConfig& config() const { return config_; }

  void start() {
    if (thread_.joinable()) return;
    accept();
    schedule_poll();
    thread_ = std::thread([this] { io_.run(); });
  }

  void stop() {
    if (!thread_.joinable()) return;
    asio::post(io_, [this] {
      stopping_ = true;  // a poll already due runs after the cancel: it must not re-arm
      asio::error_code ec;
      acceptor_.close(ec);
      poll_timer_.cancel();
      for (auto& c : clients_) close(*c);
      clients_.clear();
    });
    thread_.join();  // run() returns once the closed sockets' handlers have run
  }

  void offer(const rt::Snapshot& s) noexcept {
    if (s.tick.t_ns < next_ns_) return;
    next_ns_ = std::max(next_ns_ + interval_ns_, s.tick.t_ns);
    if (next_ns_ <= s.tick.t_ns) next_ns_ = s.tick.t_ns + interval_ns_;
    box_.write(Sample{s.tick.t_ns, s.tick.pose, s.tick.force, s.tick.u});
    offered_.fetch_add(1, std::memory_order_relaxed);
  }

  std::size_t client_count() const { return client_count_.load(std::memory_order_relaxed); }

  IgtlCounters counters() const {
    IgtlCounters c;
    c.accepted = accepted_.load();
    c.refused = refused_.load();
    c.samples_offered = offered_.load();
    c.samples_sent = sent_.load();
    c.samples_dropped = dropped_.load();
    c.timeouts = timeouts_.load();
    return c;
  }

 private:
  struct Client {
    explicit Client(tcp::socket s) : socket(std::move(s)) {}
    tcp::socket socket;
    std::deque<Bytes> queue;  // front: in flight when writing
    std::size_t in_flight = 0;
    std::int64_t write_started_ns = 0;
    bool closed = false;
    std::array<unsigned char, 4096> discard{};
  };
  using ClientPtr = std::shared_ptr<Client>;

  void accept() {
    acceptor_.async_accept([this](const asio::error_code& ec, tcp::socket socket) {
      if (ec == asio::error::operation_aborted || stopping_ || !acceptor_.is_open()) return;
      if (!ec) {
        if (clients_.size() >= config_.max_clients) {
          refused_.fetch_add(1);
          asio::error_code ignored;
          socket.close(ignored);
        } else {
          asio::error_code ignored;
          socket.set_option(tcp::no_delay(true), ignored);
          if (config_.send_buffer_bytes > 0)
            socket.set_option(asio::socket_base::send_buffer_size(config_.send_buffer_bytes),
                              ignored);
          auto c = std::make_shared<Client>(std::move(socket));
          clients_.push_back(c);
          client_count_.store(clients_.size());
          accepted_.fetch_add(1);
          read(c);
        }
      }
      accept();
    });
  }

  // What a client sends (Slicer's GET_/STT_ queries, anything) is read and discarded: no request
  // is answered, so nothing a client sends can make the server spend more than this buffer.
  void read(const ClientPtr& c) {
    c->socket.async_read_some(asio::buffer(c->discard),
                              [this, c](const asio::error_code& ec, std::size_t) {
                                if (c->closed) return;
                                if (ec) return drop(c);
                                read(c);
                              });
  }

  void close(Client& c) {
    if (c.closed) return;
    c.closed = true;
    asio::error_code ignored;
    c.socket.shutdown(tcp::socket::shutdown_both, ignored);
    c.socket.close(ignored);
  }

  void drop(const ClientPtr& c) {
    close(*c);
    clients_.erase(std::remove(clients_.begin(), clients_.end(), c), clients_.end());
    client_count_.store(clients_.size());
  }

  void schedule_poll() {
    // Four looks per sample interval (at least every 1 ms apart): a sample waits at most a
    // quarter interval here.
    const auto wait = std::chrono::nanoseconds(std::max<std::int64_t>(interval_ns_ / 4, 1'000'000));
    poll_timer_.expires_after(wait);
    poll_timer_.async_wait([this](const asio::error_code& ec) {
      if (ec || stopping_) return;
      poll();
      schedule_poll();
    });
  }

  void poll() {
    const std::int64_t now = rt::monotonic_ns();
    if (config_.write_timeout_s > 0.0) {
      const auto limit = static_cast<std::int64_t>(config_.write_timeout_s * 1e9);
      std::vector<ClientPtr> stalled;
      for (const ClientPtr& c : clients_)
        if (c->in_flight > 0 && now - c->write_started_ns > limit) stalled.push_back(c);
      for (const ClientPtr& c : stalled) {
        timeouts_.fetch_add(1);
        drop(c);
      }
    }
    Sample s;
    if (!box_.read(s) || clients_.empty()) return;
    Bytes bytes = pack(s);
    for (const ClientPtr& c : clients_) {
      // The oldest sample not already being written goes first.
      if (c->queue.size() - c->in_flight >= config_.queue_samples) {
        c->queue.erase(c->queue.begin() + static_cast<std::ptrdiff_t>(c->in_flight));
        dropped_.fetch_add(1);
      }
      c->queue.push_back(bytes);
      sent_.fetch_add(1);
      pump(c);
    }
  }

  Bytes pack(const Sample& s) const {
    std::uint32_t sec = 0, nsec = 0;
    wall_time_of(s.t_ns, sec, nsec);
    auto out = std::make_shared<std::vector<unsigned char>>();
    out->reserve(3 * 106);
    append_transform(*out, config_.tool_name, ras_pose(frame_, s.pose), sec, nsec);
    append_transform(*out, config_.force_name, translation(ras_vector(frame_, s.force)), sec, nsec);
    append_transform(*out, config_.u_name, translation(ras_vector(frame_, s.u)), sec, nsec);
    return out;
  }

  void pump(const ClientPtr& c) {
    if (c->closed || c->in_flight > 0 || c->queue.empty()) return;
    std::vector<asio::const_buffer> buffers;
    for (const Bytes& b : c->queue) buffers.emplace_back(asio::buffer(*b));
    c->in_flight = c->queue.size();
    c->write_started_ns = rt::monotonic_ns();
    asio::async_write(c->socket, buffers, [this, c](const asio::error_code& ec, std::size_t) {
      if (c->closed) return;
      if (ec) return drop(c);
      c->queue.erase(c->queue.begin(),
                     c->queue.begin() + static_cast<std::ptrdiff_t>(c->in_flight));
      c->in_flight = 0;
      pump(c);
    });
  }

  IgtlConfig config_;
  Matrix4 frame_;
  std::int64_t interval_ns_ = 0;
  asio::io_context io_;
  tcp::acceptor acceptor_;
  asio::steady_timer poll_timer_{io_};
  std::thread thread_;
  std::vector<ClientPtr> clients_;
  bool stopping_ = false;  // io thread only
  // offer()'s side (the palp.v1 io thread).
  std::int64_t next_ns_ = 0;
  rt::LatestBox<Sample> box_;
  std::atomic<std::size_t> client_count_{0};
  std::atomic<std::uint64_t> accepted_{0}, refused_{0}, offered_{0}, sent_{0}, dropped_{0},
      timeouts_{0};
};

IgtlServer::IgtlServer(IgtlConfig config, const Grid& grid)
    : impl_(std::make_unique<Impl>(std::move(config), grid)) {}
IgtlServer::~IgtlServer() = default;
std::uint16_t IgtlServer::port() const {
  return impl_->port();
}
const IgtlConfig& IgtlServer::config() const {
  return impl_->config();
}
void IgtlServer::start() {
  impl_->start();
}
void IgtlServer::stop() {
  impl_->stop();
}
void IgtlServer::offer(const rt::Snapshot& snapshot) noexcept {
  impl_->offer(snapshot);
}
std::size_t IgtlServer::client_count() const {
  return impl_->client_count();
}
IgtlCounters IgtlServer::counters() const {
  return impl_->counters();
}

}  // namespace palp::interop
