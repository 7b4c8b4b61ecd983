// A client's bounded queues and the graveyard of dropped ones: see client_queue.hpp.
#include "net/client_queue.hpp"

#include <utility>

namespace palp::net {

void Graveyard::bury(std::deque<Bytes>&& messages) {
  if (!messages.empty()) queues_.push_back(std::move(messages));
  messages = {};
}

std::size_t Graveyard::free_some(std::size_t budget) {
  while (budget > 0 && !queues_.empty()) {
    std::deque<Bytes>& q = queues_.front();
    while (budget > 0 && !q.empty()) {
      q.pop_back();
      --budget;
    }
    if (q.empty()) queues_.pop_front();
  }
  return size();
}

std::size_t Graveyard::size() const {
  std::size_t n = 0;
  for (const auto& q : queues_) n += q.size();
  return n;
}

bool ClientQueue::push_message(Bytes message) {
  bytes_ += cost(message);
  messages_.push_back(std::move(message));
  return within_bound();
}

bool ClientQueue::push_scene(Bytes scene) {
  if (scene_) bytes_ -= cost(scene_);
  bytes_ += cost(scene);
  scene_ = std::move(scene);
  return within_bound();
}

void ClientQueue::push_frame(Bytes frame) {
  bytes_ += cost(frame);
  frames_.push_back(std::move(frame));
  while (!frames_.empty() && (frames_.size() > max_frames_ || bytes_ > max_bytes_))
    drop_oldest_frame();
}

void ClientQueue::drop_frames() {
  while (!frames_.empty()) drop_oldest_frame();
}

std::size_t ClientQueue::take(std::vector<Bytes>& out, bool with_frames) {
  for (Bytes& m : messages_) {
    bytes_ -= cost(m);
    out.push_back(std::move(m));
  }
  messages_.clear();
  if (scene_) {
    bytes_ -= cost(scene_);
    out.push_back(std::move(scene_));
    scene_ = nullptr;
  }
  if (!with_frames) return 0;
  const std::size_t n = frames_.size();
  for (Bytes& f : frames_) {
    bytes_ -= cost(f);
    out.push_back(std::move(f));
  }
  frames_.clear();
  return n;
}

void ClientQueue::bury(Graveyard& graveyard) {
  graveyard.bury(std::move(messages_));
  graveyard.bury(std::move(frames_));
  scene_ = nullptr;
  bytes_ = 0;
}

void ClientQueue::drop_oldest_frame() {
  bytes_ -= cost(frames_.front());
  frames_.pop_front();
  ++frames_dropped_;
}

bool ClientQueue::within_bound() {
  while (bytes_ > max_bytes_ && !frames_.empty()) drop_oldest_frame();
  return bytes_ <= max_bytes_;
}

}  // namespace palp::net
