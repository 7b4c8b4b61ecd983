// Encoded render-volume chunks, shared and encoded in parallel: see volume_cache.hpp.
#include "net/volume_cache.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

#include "base/parallel.hpp"
#include "net/protocol.hpp"

namespace palp::net {

namespace {
bool same_plan(const VolumePlan& a, const VolumePlan& b) {
  return a.step == b.step && a.dims == b.dims && a.offset == b.offset && a.slab == b.slab &&
         a.chunks == b.chunks && a.hu == b.hu && a.bone == b.bone && a.deflate == b.deflate &&
         a.labels == b.labels;
}
}  // namespace

Bytes VolumeCache::Frames::frame(std::uint32_t index) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return index < frames_.size() ? frames_[index] : nullptr;
}

VolumeCache::VolumeCache(const SceneDescription& scene, std::size_t chunk_bytes,
                         std::function<void()> notify, bool warm, unsigned threads,
                         std::size_t max_plans)
    : scene_(scene),
      chunk_bytes_(chunk_bytes),
      notify_(std::move(notify)),
      threads_(thread_count_or_default(threads)),
      max_plans_(std::max<std::size_t>(1, max_plans)),
      body_box_(scene.body ? net::body_box(*scene.body, kCropMarginMm) : VoxelBox{}) {
  if (warm && scene.fields) {
    const VolumePlan p = plan(kViewerDefaultRequest);
    if (p.chunks > 0) get(p);
  }
}

VolumeCache::~VolumeCache() {
  const std::lock_guard<std::mutex> lock(mutex_);
  for (Worker& w : workers_)
    if (const auto frames = w.frames.lock()) frames->stop_ = true;
  for (Worker& w : workers_) w.thread.join();
}

VolumePlan VolumeCache::plan(const VolumeRequest& request) const {
  return plan_volume(scene_, request, chunk_bytes_, &body_box_);
}

std::shared_ptr<const VolumeCache::Frames> VolumeCache::get(const VolumePlan& plan) {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::erase_if(workers_, [](Worker& w) {
    if (!w.done->load()) return false;
    w.thread.join();
    return true;
  });
  for (const auto& e : entries_)
    if (same_plan(e->plan_, plan)) return e;
  if (entries_.size() >= max_plans_) entries_.erase(entries_.begin());  // the oldest
  auto frames = std::make_shared<Frames>(plan);
  entries_.push_back(frames);
  const unsigned n = std::min<unsigned>(threads_, std::max<std::uint32_t>(1, plan.chunks));
  for (unsigned t = 0; t < n; ++t) {
    auto done = std::make_shared<std::atomic<bool>>(false);
    std::weak_ptr<Frames> weak = frames;
    workers_.push_back({std::thread([this, weak, done] {
                          yield_to_live_frames();
                          encode(weak);
                          done->store(true);
                        }),
                        weak, done});
  }
  return frames;
}

// An encoder runs ten nice levels below its caller, so that on a busy machine a volume being
// deflated for a joining station never starves the io thread that serves every station's live
// frames (seen: the loop's ring to the io thread overflowing for 0.4-0.5 s while a late joiner's
// volume was encoded at load 6). Best effort: a refusal leaves the thread as it was.
void VolumeCache::yield_to_live_frames() {
  const auto tid = static_cast<id_t>(gettid());
  errno = 0;
  const int nice_now = getpriority(PRIO_PROCESS, tid);
  if (errno == 0) (void)setpriority(PRIO_PROCESS, tid, std::min(19, nice_now + 10));
}

void VolumeCache::encode(const std::weak_ptr<Frames>& weak) const {
  for (;;) {
    const std::shared_ptr<Frames> frames = weak.lock();  // nobody wants it any more: stop
    if (!frames || frames->stop_) return;
    const VolumePlan& plan = frames->plan_;
    const std::uint32_t index = frames->next_.fetch_add(1);
    if (index >= plan.chunks) return;
    v1::ServerMessage m;
    fill_volume_chunk(scene_, plan, index * plan.slab, index, m.mutable_volume());
    Bytes bytes = frame_of(m);
    {
      const std::lock_guard<std::mutex> lock(frames->mutex_);
      frames->frames_[index] = std::move(bytes);
    }
    frames->encoded_.fetch_add(1);
    if (notify_) notify_();
  }
}

}  // namespace palp::net
