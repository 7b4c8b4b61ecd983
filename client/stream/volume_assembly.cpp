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
#include "wire/volume_codec.hpp"

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

template <class Bad>
void check_size(const std::string& bytes, std::size_t expected, const char* name, const Bad& bad) {
  if (bytes.size() != expected)
    throw bad(std::string(name) + " has " + std::to_string(bytes.size()) + " bytes, expected " +
              std::to_string(expected));
}

}  // namespace

// Chunk 0's placement, checked: dimensions and spacing, a crop's offset, against the scene's
// grid and what the client asked for (max_dim), before anything is allocated.
VolumeAssembly::Geometry VolumeAssembly::chunk0_geometry(const v1::VolumeChunk& chunk,
                                                         std::uint32_t max_dim,
                                                         const SceneGrid* scene,
                                                         const std::string& where) {
  const auto bad = [&](const std::string& why) { return ProtocolViolation(where + why); };
  Geometry g;
  for (int i = 0; i < 3; ++i) {
    g.dims[i] = chunk.dims(i);
    g.spacing[i] = chunk.spacing(i);
    if (g.dims[i] < 1 || g.dims[i] > kMaxAxis)
      throw bad("dimension " + std::to_string(g.dims[i]) + " out of 1.." +
                std::to_string(kMaxAxis));
    if (!positive_finite(g.spacing[i])) throw bad("spacing must be finite and > 0");
  }
  if (g.dims[0] * g.dims[1] * g.dims[2] > kMaxVoxels) throw bad("more than 2^28 voxels");
  if (chunk.chunk_count() > g.dims[2]) throw bad("more chunks than slices");
  // A cropped volume (offset): a box of the grid's voxels at the step; else the whole grid.
  if (chunk.offset_size() != 0 && chunk.offset_size() != 3) throw bad("needs 0 or 3 offsets");
  for (int i = 0; i < chunk.offset_size(); ++i) {
    g.offset[i] = chunk.offset(i);
    if (g.offset[i] < 0 || g.offset[i] > kMaxAxis * std::int64_t{chunk.step()})
      throw bad("offset " + std::to_string(g.offset[i]) + " out of range");
  }
  const bool cropped = chunk.offset_size() == 3;
  if (scene)
    for (int i = 0; i < 3; ++i) {
      const std::int64_t expect = (scene->dims[i] + chunk.step() - 1) / chunk.step();
      if (!cropped && g.dims[i] != expect)
        throw bad("dimension " + std::to_string(g.dims[i]) + " along axis " + std::to_string(i) +
                  ", the scene's grid at step " + std::to_string(chunk.step()) + " has " +
                  std::to_string(expect));
      if (cropped && g.offset[i] + (g.dims[i] - 1) * std::int64_t{chunk.step()} >= scene->dims[i])
        throw bad("the cropped box leaves the scene's grid along axis " + std::to_string(i));
      const double sp = scene->spacing[i] * chunk.step();
      if (std::abs(g.spacing[i] - sp) > 1e-6 * sp) throw bad("spacing does not match the scene");
    }
  for (int i = 0; i < 3; ++i)
    if (g.dims[i] > static_cast<std::int64_t>(max_dim))
      throw bad("dimension " + std::to_string(g.dims[i]) + " along axis " + std::to_string(i) +
                ": this client asked for at most " + std::to_string(max_dim) + " a side");
  if (chunk.k_begin() != 0)
    throw bad("k_begin " + std::to_string(chunk.k_begin()) + ", expected 0");
  if (chunk.k_count() < 1 || chunk.k_count() > g.dims[2])
    throw bad("slices 0+" + std::to_string(chunk.k_count()) + " outside 0.." +
              std::to_string(g.dims[2]));
  return g;
}

VolumeAssembly::Added VolumeAssembly::add(const v1::VolumeChunk& chunk, std::uint32_t max_dim,
                                          const SceneGrid* scene) {
  const std::string where = "volume chunk " + std::to_string(chunk.chunk_index()) + ": ";
  const auto bad = [&](const std::string& why) { return ProtocolViolation(where + why); };
  if (chunk.dims_size() != 3 || chunk.spacing_size() != 3) throw bad("needs 3 dims and spacings");
  if (chunk.step() < 1) throw bad("step 0");
  if (chunk.chunk_count() < 1 || chunk.chunk_index() >= chunk.chunk_count())
    throw bad("index " + std::to_string(chunk.chunk_index()) + " of " +
              std::to_string(chunk.chunk_count()));
  if (max_dim == 0) throw bad("a render volume this client did not ask for");
  if (chunk.chunk_index() == 0) {
    if (active_) throw bad("a new volume before the last one was complete");
    begin(chunk, chunk0_geometry(chunk, max_dim, scene, where), scene, where);
  } else {
    check_next(chunk, where);
  }
  const RenderVolume& v = *volume_;
  if (chunk.k_begin() != next_k_)
    throw bad("k_begin " + std::to_string(chunk.k_begin()) + ", expected " +
              std::to_string(next_k_));
  if (chunk.k_count() < 1 || chunk.k_begin() + std::int64_t{chunk.k_count()} > v.dims[2])
    throw bad("slices " + std::to_string(chunk.k_begin()) + "+" + std::to_string(chunk.k_count()) +
              " outside 0.." + std::to_string(v.dims[2]));
  const std::size_t slice = static_cast<std::size_t>(v.dims[0] * v.dims[1]);
  copy_fields(chunk, slice * chunk.k_count(), slice * chunk.k_begin(),
              scene ? scene->max_label : 0, where);
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

// Chunk 0's fields (which come, and raw ones their sizes now; deflated ones are checked as they
// inflate, bounded by what the slices need), then the volume allocated.
void VolumeAssembly::begin(const v1::VolumeChunk& chunk, const Geometry& g, const SceneGrid* scene,
                           const std::string& where) {
  const auto bad = [&](const std::string& why) { return ProtocolViolation(where + why); };
  const std::size_t voxels0 = static_cast<std::size_t>(g.dims[0] * g.dims[1]) * chunk.k_count();
  const bool has_bone = !chunk.d_bone().empty(), has_hu = !chunk.hu().empty(),
             has_labels = !chunk.labels().empty(), deflate = chunk.deflate();
  if (has_hu != !chunk.body().empty()) throw bad("hu and body come together");
  if (has_labels && !(scene && scene->max_label > 0))
    throw bad("structure labels, but SceneInfo listed no structures");
  if (!deflate) {
    check_size(chunk.d_surf(), voxels0 * sizeof(float), "d_surf", bad);
    if (has_bone) check_size(chunk.d_bone(), voxels0 * sizeof(float), "d_bone", bad);
    if (has_hu) check_size(chunk.hu(), voxels0 * sizeof(std::int16_t), "hu", bad);
    if (has_hu) check_size(chunk.body(), voxels0, "body", bad);
    if (has_labels) check_size(chunk.labels(), voxels0, "labels", bad);
  }
  const std::size_t voxels = static_cast<std::size_t>(g.dims[0] * g.dims[1] * g.dims[2]);
  *this = VolumeAssembly{};
  active_ = true;
  offset_size_ = chunk.offset_size();
  offset_ = g.offset;
  step_ = chunk.step();
  chunk_count_ = chunk.chunk_count();
  has_bone_ = has_bone, has_hu_ = has_hu, has_labels_ = has_labels, deflate_ = deflate;
  try {
    auto volume = std::make_shared<RenderVolume>();
    volume->dims = g.dims;
    volume->spacing = g.spacing;
    volume->step = chunk.step();
    for (int i = 0; i < 3; ++i)  // grid voxel offset * the grid's spacing
      volume->origin[i] = static_cast<double>(g.offset[i]) * g.spacing[i] / chunk.step();
    volume->d_surf.resize(voxels);
    if (has_bone_) volume->d_bone.resize(voxels);
    if (has_hu_) {
      volume->hu.resize(voxels);
      volume->body.resize(voxels);
    }
    if (has_labels_) volume->labels.resize(voxels);
    volume_ = std::move(volume);
  } catch (const std::bad_alloc&) {
    *this = VolumeAssembly{};
    throw ResourceError("not enough memory for the render volume (" + std::to_string(voxels) +
                        " voxels)");
  }
}

// A later chunk: the next one, of the volume chunk 0 began.
void VolumeAssembly::check_next(const v1::VolumeChunk& chunk, const std::string& where) const {
  const auto bad = [&](const std::string& why) { return ProtocolViolation(where + why); };
  if (!active_) throw bad("without chunk 0");
  if (chunk.chunk_index() != next_chunk_) throw bad("expected chunk " + std::to_string(next_chunk_));
  if (chunk.step() != step_ || chunk.chunk_count() != chunk_count_)
    throw bad("step or chunk count differs from chunk 0");
  if (chunk.deflate() != deflate_) throw bad("deflate differs from chunk 0");
  if (chunk.offset_size() != offset_size_) throw bad("offset differs from chunk 0");
  for (int i = 0; i < chunk.offset_size(); ++i)
    if (chunk.offset(i) != offset_[i]) throw bad("offset differs from chunk 0");
  for (int i = 0; i < 3; ++i)
    if (chunk.dims(i) != volume_->dims[i] || chunk.spacing(i) != volume_->spacing[i])
      throw bad("dims or spacing differ from chunk 0");
}

// Each field's raw bytes (inflated to exactly the slices' size, never more), then copied in.
void VolumeAssembly::copy_fields(const v1::VolumeChunk& chunk, std::size_t voxels,
                                 std::size_t offset, std::uint32_t max_label,
                                 const std::string& where) {
  const auto bad = [&](const std::string& why) { return ProtocolViolation(where + why); };
  const auto present = [&](const std::string& bytes, bool expected, const char* name) {
    if (bytes.empty() == expected)
      throw bad(std::string(name) + (expected ? " missing" : " not in chunk 0"));
  };
  present(chunk.d_surf(), true, "d_surf");
  present(chunk.d_bone(), has_bone_, "d_bone");
  present(chunk.hu(), has_hu_, "hu");
  present(chunk.body(), has_hu_, "body");
  present(chunk.labels(), has_labels_, "labels");
  std::string scratch;
  const auto raw = [&](const std::string& bytes, std::size_t expected,
                       const char* name) -> const std::string& {
    if (!deflate_) {
      check_size(bytes, expected, name, bad);
      return bytes;
    }
    if (!wire::inflate_exact(bytes, expected, scratch))
      throw bad(std::string(name) + ": not a zlib stream of " + std::to_string(expected) +
                " bytes");
    return scratch;
  };
  copy_floats(raw(chunk.d_surf(), voxels * sizeof(float), "d_surf"),
              volume_->d_surf.data() + offset);
  if (has_bone_)
    copy_floats(raw(chunk.d_bone(), voxels * sizeof(float), "d_bone"),
                volume_->d_bone.data() + offset);
  if (has_hu_) {
    const std::string& hu = raw(chunk.hu(), voxels * sizeof(std::int16_t), "hu");
    std::memcpy(volume_->hu.data() + offset, hu.data(), hu.size());
    if constexpr (std::endian::native == std::endian::big)
      for (std::size_t i = 0; i < voxels; ++i)
        volume_->hu[offset + i] = static_cast<std::int16_t>(
            __builtin_bswap16(static_cast<std::uint16_t>(volume_->hu[offset + i])));
    const std::string& body = raw(chunk.body(), voxels, "body");
    for (std::size_t i = 0; i < voxels; ++i) volume_->body[offset + i] = body[i] != 0 ? 1 : 0;
  }
  if (has_labels_) {
    const std::string& labels = raw(chunk.labels(), voxels, "labels");
    for (std::size_t i = 0; i < voxels; ++i) {
      const auto label = static_cast<std::uint8_t>(labels[i]);
      if (label > max_label)
        throw bad("structure label " + std::to_string(label) + ", SceneInfo lists up to " +
                  std::to_string(max_label));
      volume_->labels[offset + i] = label;
    }
  }
}

}  // namespace palp::view::net
