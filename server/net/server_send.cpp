// The palpd network server's write side (server_impl.hpp): what is queued for each client, the
// one write in flight per client gathering everything queued, errors, and closing a connection.
#include <string>
#include <utility>

#include "net/protocol.hpp"
#include "net/server_impl.hpp"

namespace palp::net {

// ------------------------------------------------------------------ write
void Server::Impl::pump(const SessionPtr& s) {
  if (s->writing || s->closed) return;
  s->inflight.clear();
  s->buffers.clear();
  std::size_t frames_now = 0;
  s->queue.take(s->inflight, false);
  if (s->history) s->inflight.push_back(std::exchange(s->history, nullptr));
  if (!s->closing && !s->ready && s->volume.chunks > 0 && s->inflight.empty())
    if (Bytes b = next_volume_chunk(*s)) s->inflight.push_back(std::move(b));
  if (!s->closing && s->ready) frames_now = s->queue.take(s->inflight, true);
  if (s->inflight.empty()) {
    if (s->closing) close(*s);
    return;
  }
  for (const Bytes& b : s->inflight) s->buffers.push_back(asio::buffer(*b));
  s->writing = true;
  s->write_started_ns = rt::monotonic_ns();
  s->stream.async_write(s->buffers, [this, s, frames_now](const asio::error_code& ec, std::size_t) {
    s->writing = false;
    if (s->closed) return;
    if (ec) {
      close(*s);
      return;
    }
    s->frames_sent += frames_now;
    frames_sent_.fetch_add(frames_now);
    pump(s);
  });
}

// Queue a message / replace the queued SceneInfo for `s`; false (and the client dropped) when
// its queue exceeds max_queue_bytes even after its stale frames went.
bool Server::Impl::queue(Session& s, Bytes bytes) {
  if (s.closed) return false;
  return counted(s, s.queue.push_message(std::move(bytes)));
}

bool Server::Impl::queue_scene(Session& s, Bytes scene) {
  if (s.closed) return false;
  return counted(s, s.queue.push_scene(std::move(scene)));
}

// Adds the frames the queue dropped to the server's count; drops the client when its queue
// is over the bound.
bool Server::Impl::counted(Session& s, bool within_bound) {
  const std::uint64_t dropped = s.queue.frames_dropped();
  frames_dropped_.fetch_add(dropped - s.frames_dropped_counted);
  s.frames_dropped_counted = dropped;
  if (within_bound) return true;
  overflows_.fetch_add(1);
  // an Error could not get through a queue the client does not read either
  close(s, "dropped: its queue is over --queue-bytes (it does not read)");
  return false;
}

void Server::Impl::send(const SessionPtr& s, Bytes bytes) {
  if (queue(*s, std::move(bytes))) pump(s);
}

void Server::Impl::error(const SessionPtr& s, v1::Error::Code code, const std::string& reason) {
  protocol_errors_.fetch_add(1);
  send(s, error_frame(code, reason, false));
}

void Server::Impl::fatal(const SessionPtr& s, v1::Error::Code code, const std::string& reason) {
  if (!s->end_logged) log_client(who(*s) + (s->welcomed ? " dropped: " : " refused: ") + reason);
  s->end_logged = true;
  protocol_errors_.fetch_add(1);
  rejected_.fetch_add(1);
  s->queue.drop_frames();
  counted(*s, true);
  s->closing = true;
  send(s, error_frame(code, reason, true));
}

// Closes the socket; the queue goes to the graveyard, freed a slice at a time (each poll).
void Server::Impl::close(Session& s, const char* why) {
  if (s.closed) return;
  s.closed = true;
  if (!s.end_logged && s.welcomed) log_client(who(s) + " " + why);
  s.end_logged = true;
  s.stream.close();
  s.queue.bury(graveyard_);
}

// ------------------------------------------------------------------ the log
void Server::Impl::log_client(const std::string& line) {
  if (config_.log_clients) client_log_.say(line);
}

std::string Server::Impl::who(const Session& s) {
  return describe_client(s.id, s.address, s.welcomed, s.role == v1::CONTROLLER,
                         s.cert.verified ? s.name + " [" + s.cert.subject + "]" : s.name);
}

}  // namespace palp::net
