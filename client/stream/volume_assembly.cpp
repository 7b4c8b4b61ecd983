// Render-volume assembly: see volume_assembly.hpp.
#include "stream/volume_assembly.hpp"

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <new>
#include <string>
#include <utility>

#include "base/errors.hpp"
#include "stream/protocol_checks.hpp"

namespace palp::view::net {

namespace {

constexpr std::int64_t kMaxAxis = 1 << 16;      // render volume: voxels per axis
constexpr std::int64_t kMaxVoxels = 1LL << 28;  // render volume: voxels in all (1 GiB a map)

// Little-endian float32 bytes -> floats.
void copy_floats(const std::string& bytes, float* out) {
  std::memcpy(out, bytes.data(), bytes.size());
  if constexpr (std::endian::native == std::endian::big) {
    for (std::size_t i = 0; i < bytes.size() / sizeof(float); ++i) {
      std::uint32_t u;
      std::memcpy(&u, out + i, sizeof u);
      u = __builtin_bswap32(u);
      std::memcpy(out + i, &u, sizeof u);
    }
  }
}

}  // namespace

VolumeAssembly::Added VolumeAssembly::add(const v1::VolumeChunk& chunk, std::uint32_t max_dim,
                                          const SceneGrid* scene) {
  const bool requested = max_dim > 0;
  const std::string where = "volume chunk " + std::to_string(chunk.chunk_index()) + ": ";
  const auto bad = [&](const std::string& why) { return ProtocolViolation(where + why); };
  if (chunk.dims_size() != 3 || chunk.spacing_size() != 3) throw bad("needs 3 dims and spacings");
  if (chunk.step() < 1) throw bad("step 0");
  if (chunk.chunk_count() < 1 || chunk.chunk_index() >= chunk.chunk_count())
    throw bad("index " + std::to_string(chunk.chunk_index()) + " of " +
              std::to_string(chunk.chunk_count()));
  if (!requested) throw bad("a render volume this client did not ask for");
  if (chunk.chunk_index() == 0) {
    if (active_) throw bad("a new volume before the last one was complete");
    std::array<std::int64_t, 3> dims{};
    std::array<double, 3> spacing{};
    for (int i = 0; i < 3; ++i) {
      dims[i] = chunk.dims(i);
      spacing[i] = chunk.spacing(i);
      if (dims[i] < 1 || dims[i] > kMaxAxis)
        throw bad("dimension " + std::to_string(dims[i]) + " out of 1.." +
                  std::to_string(kMaxAxis));
      if (!positive_finite(spacing[i])) throw bad("spacing must be finite and > 0");
    }
    if (dims[0] * dims[1] * dims[2] > kMaxVoxels) throw bad("more than 2^28 voxels");
    if (chunk.chunk_count() > dims[2]) throw bad("more chunks than slices");
    if (scene)
      for (int i = 0; i < 3; ++i) {
        const std::int64_t expect = (scene->dims[i] + chunk.step() - 1) / chunk.step();
        if (dims[i] != expect)
          throw bad("dimension " + std::to_string(dims[i]) + " along axis " + std::to_string(i) +
                    ", the scene's grid at step " + std::to_string(chunk.step()) + " has " +
                    std::to_string(expect));
        const double sp = scene->spacing[i] * chunk.step();
        if (std::abs(spacing[i] - sp) > 1e-6 * sp) throw bad("spacing does not match the scene");
      }
    // Within what this client asked for, and chunk 0's own bytes what its slices need, before
    // anything is allocated.
    for (int i = 0; i < 3; ++i)
      if (dims[i] > static_cast<std::int64_t>(max_dim))
        throw bad("dimension " + std::to_string(dims[i]) + " along axis " + std::to_string(i) +
                  ": this client asked for at most " + std::to_string(max_dim) + " a side");
    if (chunk.k_begin() != 0)
      throw bad("k_begin " + std::to_string(chunk.k_begin()) + ", expected 0");
    if (chunk.k_count() < 1 || chunk.k_count() > dims[2])
      throw bad("slices 0+" + std::to_string(chunk.k_count()) + " outside 0.." +
                std::to_string(dims[2]));
    const std::size_t bytes0 =
        static_cast<std::size_t>(dims[0] * dims[1]) * chunk.k_count() * sizeof(float);
    if (chunk.d_surf().size() != bytes0)
      throw bad("d_surf has " + std::to_string(chunk.d_surf().size()) + " bytes, expected " +
                std::to_string(bytes0));
    if (!chunk.d_bone().empty() && chunk.d_bone().size() != bytes0)
      throw bad("d_bone has " + std::to_string(chunk.d_bone().size()) + " bytes, expected " +
                std::to_string(bytes0));
    const std::size_t voxels = static_cast<std::size_t>(dims[0] * dims[1] * dims[2]);
    *this = VolumeAssembly{};
    active_ = true;
    step_ = chunk.step();
    chunk_count_ = chunk.chunk_count();
    has_bone_ = !chunk.d_bone().empty();
    try {
      auto volume = std::make_shared<RenderVolume>();
      volume->dims = dims;
      volume->spacing = spacing;
      volume->step = chunk.step();
      volume->d_surf.resize(voxels);
      if (has_bone_) volume->d_bone.resize(voxels);
      volume_ = std::move(volume);
    } catch (const std::bad_alloc&) {
      *this = VolumeAssembly{};
      throw ResourceError("not enough memory for the render volume (" + std::to_string(voxels) +
                          " voxels)");
    }
  } else {
    if (!active_) throw bad("without chunk 0");
    if (chunk.chunk_index() != next_chunk_)
      throw bad("expected chunk " + std::to_string(next_chunk_));
    if (chunk.step() != step_ || chunk.chunk_count() != chunk_count_)
      throw bad("step or chunk count differs from chunk 0");
    for (int i = 0; i < 3; ++i)
      if (chunk.dims(i) != volume_->dims[i] || chunk.spacing(i) != volume_->spacing[i])
        throw bad("dims or spacing differ from chunk 0");
  }
  const RenderVolume& v = *volume_;
  if (chunk.k_begin() != next_k_)
    throw bad("k_begin " + std::to_string(chunk.k_begin()) + ", expected " +
              std::to_string(next_k_));
  if (chunk.k_count() < 1 || chunk.k_begin() + std::int64_t{chunk.k_count()} > v.dims[2])
    throw bad("slices " + std::to_string(chunk.k_begin()) + "+" + std::to_string(chunk.k_count()) +
              " outside 0.." + std::to_string(v.dims[2]));
  const std::size_t slice = static_cast<std::size_t>(v.dims[0] * v.dims[1]);
  const std::size_t bytes = slice * chunk.k_count() * sizeof(float);
  if (chunk.d_surf().size() != bytes)
    throw bad("d_surf has " + std::to_string(chunk.d_surf().size()) + " bytes, expected " +
              std::to_string(bytes));
  if (chunk.d_bone().size() != (has_bone_ ? bytes : 0))
    throw bad("d_bone has " + std::to_string(chunk.d_bone().size()) + " bytes, expected " +
              std::to_string(has_bone_ ? bytes : 0));
  const std::size_t offset = slice * chunk.k_begin();
  copy_floats(chunk.d_surf(), volume_->d_surf.data() + offset);
  if (has_bone_) copy_floats(chunk.d_bone(), volume_->d_bone.data() + offset);
  next_k_ += chunk.k_count();
  ++next_chunk_;
  const bool complete = next_chunk_ == chunk_count_;
  if (complete && next_k_ != v.dims[2])
    throw bad("the chunks cover " + std::to_string(next_k_) + " of " + std::to_string(v.dims[2]) +
              " slices");
  Added added;
  added.progress = static_cast<double>(next_k_) / static_cast<double>(volume_->dims[2]);
  if (complete) {
    added.volume = std::move(volume_);
    *this = VolumeAssembly{};
    done_ = true;
  }
  return added;
}

}  // namespace palp::view::net
