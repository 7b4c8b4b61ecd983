// Render-volume assembly (pure, no Asio): VolumeChunks checked and copied into a RenderVolume.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "palp.pb.h"
#include "stream/stream_client.hpp"

namespace palp::view::net {

// The scene's grid (SceneInfo), which the render volume must match at its step.
struct SceneGrid {
  std::array<std::int64_t, 3> dims{};
  std::array<double, 3> spacing{};  // mm
  std::uint32_t max_label = 0;      // the largest structure label SceneInfo listed (0: none)
};

class VolumeAssembly {
 public:
  struct Added {
    double progress = 0;                   // slices received / slices in the volume
    std::shared_ptr<RenderVolume> volume;  // the complete volume after its last chunk, else null
  };

  // Validates a chunk against the first one, the scene and the bytes present, then copies it in.
  // `max_dim`: the voxels per axis this client asked for at most (0: it asked for no volume);
  // `scene`: null before SceneInfo. Nothing is allocated before chunk 0 is known to be
  // consistent (dimensions within max_dim, its own bytes those its slices need). Structure
  // labels come only with a scene that lists structures, exactly a byte a voxel, none above the
  // scene's largest label. Throws ProtocolViolation, or ResourceError when the volume does not
  // fit in memory.
  Added add(const v1::VolumeChunk& chunk, std::uint32_t max_dim, const SceneGrid* scene);

  bool active() const { return active_; }  // chunk 0 received, the last chunk not yet

 private:
  bool active_ = false, done_ = false;
  std::uint32_t step_ = 0, chunk_count_ = 0, next_chunk_ = 0;
  std::int64_t next_k_ = 0;
  struct Geometry {  // chunk 0's dims, spacing and offset, checked
    std::array<std::int64_t, 3> dims{}, offset{};
    std::array<double, 3> spacing{};
  };
  static Geometry chunk0_geometry(const v1::VolumeChunk& chunk, std::uint32_t max_dim,
                                  const SceneGrid* scene, const std::string& where);
  void begin(const v1::VolumeChunk& chunk, const Geometry& g, const SceneGrid* scene,
             const std::string& where);
  void check_next(const v1::VolumeChunk& chunk, const std::string& where) const;
  void copy_fields(const v1::VolumeChunk& chunk, std::size_t voxels, std::size_t offset,
                   std::uint32_t max_label, const std::string& where);

  bool has_bone_ = false, has_hu_ = false, has_labels_ = false, deflate_ = false;
  int offset_size_ = 0;  // 3: a cropped volume
  std::array<std::int64_t, 3> offset_{};
  std::shared_ptr<RenderVolume> volume_;
};

}  // namespace palp::view::net
