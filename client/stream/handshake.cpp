// The Hello handshake: see handshake.hpp.
#include "stream/handshake.hpp"

#include "wire/messages.hpp"

namespace palp::view::net {

std::string encode_hello(const StreamOptions& opts) {
  v1::ClientMessage m;
  v1::Hello* h = m.mutable_hello();
  h->set_protocol_version(palp::wire::kProtocolVersion);
  h->set_role(opts.controller ? v1::CONTROLLER : v1::OBSERVER);
  h->set_token(opts.token);
  h->set_client_name(opts.client_name);
  h->set_frame_rate_hz(opts.frame_rate_hz);
  h->set_volume_step(0);
  h->set_volume_max_dim(opts.volume_max_dim);
  h->set_want_contacts(opts.want_contacts);
  h->set_volume_hu(opts.volume_hu);
  h->set_volume_skip_bone(!opts.volume_bone);
  h->set_volume_deflate(opts.volume_deflate);
  h->set_volume_crop(opts.volume_crop);
  h->set_volume_labels(opts.volume_labels);
  return palp::wire::encode_frame(m);
}

std::string welcome_refusal(const v1::Welcome& w) {
  if (w.protocol_version() == palp::wire::kProtocolVersion) return "";
  return "the server speaks protocol version " + std::to_string(w.protocol_version()) +
         ", this client " + std::to_string(palp::wire::kProtocolVersion);
}

bool is_refusal(v1::Error::Code code) {
  switch (code) {
    case v1::Error::VERSION_MISMATCH:
    case v1::Error::UNAUTHORIZED:
    case v1::Error::PERMISSION_DENIED:
    case v1::Error::CONTROLLER_BUSY:
    case v1::Error::EXPECTED_HELLO:
    case v1::Error::MALFORMED:
    case v1::Error::FRAME_TOO_LARGE:
    case v1::Error::BAD_REQUEST:
      return true;
    default:
      return false;
  }
}

}  // namespace palp::view::net
