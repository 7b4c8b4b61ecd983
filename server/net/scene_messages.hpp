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

// What a client asked for in its Hello (palp.proto, Hello.volume_*).
struct VolumeRequest {
  std::uint32_t step = 0;     // 0: from max_dim
  std::uint32_t max_dim = 0;  // at most this many voxels an axis (with step 0)
  bool hu = false;            // the CT's HU and the body mask (when the scene has them)
  bool bone = true;           // d_bone (when the scene has it)
  bool deflate = false;       // byte fields as zlib streams
  bool crop = false;          // the body's bounding box only (with hu and a crop box)
  bool labels = false;        // the structures' labels (when the scene has any)
};

// A box of grid voxels [lo, hi).
struct VoxelBox {
  std::array<std::int64_t, 3> lo{}, hi{};
  bool empty() const { return !(hi[0] > lo[0] && hi[1] > lo[1] && hi[2] > lo[2]); }
};

// How the render volume goes out: every `step`-th voxel, `slab` slices a chunk.
struct VolumePlan {
  std::uint32_t step = 0;  // 0: no volume
  std::array<std::int64_t, 3> dims{};
  std::array<std::int64_t, 3> offset{};  // grid voxel of sampled voxel (0, 0, 0): a crop
  std::uint32_t slab = 1;
  std::uint32_t chunks = 0;
  bool hu = false, bone = false, deflate = false;  // what each chunk carries
  bool labels = false;                             // VolumeChunk.labels
  std::size_t voxel_bytes = 4;                     // raw bytes a voxel (all fields)
};
// The largest raw chunk palpd sends: one slice of a step is never more than this (the step
// grows until it fits), so every chunk fits the client's frame limit (16 MiB).
inline constexpr std::size_t kMaxChunkRawBytes = 12u << 20;

// The plan for `request` on `scene` (chunks of about `chunk_bytes` raw bytes). With
// request.crop, hu and a non-empty `crop` box, only that box goes out: its corner aligned down
// to the step (so its voxels are those of the uncropped volume), the step chosen so the box
// fits max_dim. `crop` is in the CT's voxels (body_box), which the maps' grid may refine
// (prep/maps/map_refine.hpp): the HU and body then go out from the CT's nearest node.
VolumePlan plan_volume(const SceneDescription& scene, const VolumeRequest& request,
                       std::size_t chunk_bytes, const VoxelBox* crop = nullptr);
// The bounding box of the body mask's set voxels grown by `margin_mm` (clamped to the grid);
// empty when the mask is.
VoxelBox body_box(const Mask& body, double margin_mm);
// The margin palpd keeps around the body in a cropped volume (the shadow and the tool's approach
// lie outside the skin; the deformation pushes inwards).
inline constexpr double kCropMarginMm = 10.0;

// Chunk `index` (slices from `k_begin`) of the plan: the maps sampled at the voxel centres, the
// HU and body mask at the same voxels. Returns the number of slices it holds.
std::uint32_t fill_volume_chunk(const SceneDescription& scene, const VolumePlan& plan,
                                std::uint32_t k_begin, std::uint32_t index, v1::VolumeChunk* out);

// Stats from the loop's counters (`rate_hz`: ticks per second since the last Stats).
void fill_stats(const rt::LoopStats& ls, const rt::HapticLoop& loop, const SceneDescription& scene,
                const ControlTarget* control, double rate_hz, std::int64_t now_ns,
                std::uint32_t clients, v1::Stats* out);

}  // namespace palp::net
