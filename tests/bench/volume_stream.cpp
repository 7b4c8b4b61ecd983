// Where the render volume's time goes between palpd and palpview, without a socket: palpd's
// composition of each chunk (sampling the maps, HU and mask; deflate), the frame encoding,
// palpview's parse and assembly (inflate, copy) and the render-scalar composition, for the
// whole grid and for the body's box (Hello.volume_crop). Prints one line per phase and a JSON
// line. Measures; never gates anything.
//
// usage: volume_stream SCENE [MAX_DIM (512)] [CHUNK_BYTES (1048576)]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "net/scene_messages.hpp"
#include "palp.pb.h"
#include "render/transfer_presets.hpp"
#include "scene/scene.hpp"
#include "stream/volume_assembly.hpp"
#include "wire/framing.hpp"
#include "wire/messages.hpp"

namespace {
double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: volume_stream SCENE [MAX_DIM] [CHUNK_BYTES]\n");
    return 2;
  }
  const auto max_dim = static_cast<std::uint32_t>(argc > 2 ? std::atoi(argv[2]) : 512);
  const std::size_t chunk_bytes = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : (1u << 20);
  palp::SceneOptions options;
  options.load_ct = true;
  const palp::Scene scene = palp::load_scene(argv[1], options);
  palp::net::SceneDescription desc;
  desc.grid = scene.grid;
  desc.fields = scene.fields;
  desc.ct = scene.ct;
  desc.body = scene.body;
  double t = now_s();
  const palp::net::VoxelBox box =
      desc.body ? palp::net::body_box(*desc.body, palp::net::kCropMarginMm) : palp::net::VoxelBox{};
  const double box_s = now_s() - t;
  const palp::net::VoxelBox tight =
      desc.body ? palp::net::body_box(*desc.body, 0.0) : palp::net::VoxelBox{};
  std::printf(
      "scene %s: %lld x %lld x %lld; body voxels [%lld,%lld) x [%lld,%lld) x [%lld,%lld); box "
      "with the margin found in %.3f s\n",
      argv[1], static_cast<long long>(scene.grid.dims[0]),
      static_cast<long long>(scene.grid.dims[1]), static_cast<long long>(scene.grid.dims[2]),
      static_cast<long long>(tight.lo[0]), static_cast<long long>(tight.hi[0]),
      static_cast<long long>(tight.lo[1]), static_cast<long long>(tight.hi[1]),
      static_cast<long long>(tight.lo[2]), static_cast<long long>(tight.hi[2]), box_s);
  const palp::view::net::SceneGrid grid{
      scene.grid.dims, {scene.grid.spacing[0], scene.grid.spacing[1], scene.grid.spacing[2]}};
  std::string json = "{";
  // whole and cropped deflated (what palpview asks), and cropped raw (the deflate's share).
  for (const int mode : {0, 1, 2}) {
    const bool crop = mode > 0, deflate = mode < 2;
    const palp::net::VolumePlan plan =
        palp::net::plan_volume(desc, {0, max_dim, true, false, deflate, crop}, chunk_bytes, &box);
    double fill_s = 0, encode_s = 0, parse_s = 0, add_s = 0;
    std::size_t wire_bytes = 0;
    palp::view::net::VolumeAssembly assembly;
    std::shared_ptr<palp::view::RenderVolume> volume;
    std::uint32_t k = 0;
    for (std::uint32_t c = 0; c < plan.chunks; ++c) {
      palp::v1::ServerMessage m;
      t = now_s();
      k += palp::net::fill_volume_chunk(desc, plan, k, c, m.mutable_volume());
      fill_s += now_s() - t;
      t = now_s();
      const std::string frame = palp::wire::encode_frame(m);
      encode_s += now_s() - t;
      wire_bytes += frame.size();
      t = now_s();
      palp::v1::ServerMessage in;
      const palp::wire::FrameView peek = palp::wire::peek_frame(
          {reinterpret_cast<const std::uint8_t*>(frame.data()), frame.size()}, 64u << 20);
      in.ParseFromArray(frame.data() + peek.prefix_bytes, static_cast<int>(peek.body_bytes));
      parse_s += now_s() - t;
      t = now_s();
      auto added = assembly.add(in.volume(), max_dim, &grid);
      add_s += now_s() - t;
      if (added.volume) volume = added.volume;
    }
    t = now_s();
    const std::vector<float> scalars =
        palp::view::compose_ct_scalar(volume->hu, volume->body, false);
    const double compose_s = now_s() - t;
    const char* name = mode == 0 ? "whole" : mode == 1 ? "cropped" : "raw";
    std::printf(
        "%-8s step %u dims %lld x %lld x %lld offset %lld,%lld,%lld chunks %u: wire %.1f MB "
        "(raw %.1f MB); palpd fill %.3f s, encode %.3f s; palpview parse %.3f s, assemble %.3f "
        "s, compose %.3f s\n",
        name, plan.step, static_cast<long long>(plan.dims[0]), static_cast<long long>(plan.dims[1]),
        static_cast<long long>(plan.dims[2]), static_cast<long long>(plan.offset[0]),
        static_cast<long long>(plan.offset[1]), static_cast<long long>(plan.offset[2]), plan.chunks,
        wire_bytes / 1e6,
        static_cast<double>(plan.dims[0] * plan.dims[1] * plan.dims[2]) * plan.voxel_bytes / 1e6,
        fill_s, encode_s, parse_s, add_s, compose_s);
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%s\"%s\":{\"wire_bytes\":%zu,\"fill_s\":%.4f,\"encode_s\":%.4f,"
                  "\"parse_s\":%.4f,\"assemble_s\":%.4f,\"compose_s\":%.4f,\"voxels\":%zu}",
                  mode > 0 ? "," : "", name, wire_bytes, fill_s, encode_s, parse_s, add_s,
                  compose_s, scalars.size());
    json += buf;
  }
  std::printf("%s}\n", json.c_str());
  return 0;
}
