// What palpd tells a client about its scene, as messages: SceneInfo (grid, patient frame, tool,
// parameters, device, registration), the render volume in chunks, and Stats. Pure message
// composition: no sockets, no sessions (server.cpp owns those and decides when each goes out).
#pragma once

#include <array>
#include <cstdint>

#include "loop/haptic_loop.hpp"
#include "net/server.hpp"
#include "palp.pb.h"

namespace palp::net {

// SceneInfo for the scene and the loop's current model, rate and device.
void fill_scene_info(const SceneDescription& scene, const rt::HapticLoop& loop, v1::SceneInfo* out);

// How the render volume goes out: every `step`-th voxel, `slab` slices a chunk.
struct VolumePlan {
  std::uint32_t step = 0;  // 0: no volume
  std::array<std::int64_t, 3> dims{};
  std::uint32_t slab = 1;
  std::uint32_t chunks = 0;
};
// The plan for a client asking `step` (0: from max_dim) or at most `max_dim` voxels an axis.
VolumePlan plan_volume(const Grid& grid, std::uint32_t step, std::uint32_t max_dim,
                       std::size_t chunk_bytes);
// Chunk `index` (slices from `k_begin`) of the plan: the maps sampled at the voxel centres.
// Returns the number of slices it holds.
std::uint32_t fill_volume_chunk(const FieldSampler& fields, const Grid& grid,
                                const VolumePlan& plan, std::uint32_t k_begin, std::uint32_t index,
                                v1::VolumeChunk* out);

// Stats from the loop's counters (`rate_hz`: ticks per second since the last Stats).
void fill_stats(const rt::LoopStats& ls, const rt::HapticLoop& loop, const SceneDescription& scene,
                const ControlTarget* control, double rate_hz, std::int64_t now_ns,
                std::uint32_t clients, v1::Stats* out);

}  // namespace palp::net
