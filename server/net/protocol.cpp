// palp.v1 conversions and checks: see protocol.hpp.
#include "net/protocol.hpp"

#include <cmath>

#include "wire/framing.hpp"

namespace palp::net {

std::shared_ptr<const std::string> frame_of(const v1::ServerMessage& message) {
  return std::make_shared<const std::string>(wire::encode_frame(message));
}

std::shared_ptr<const std::string> error_frame(v1::Error::Code code, const std::string& reason,
                                               bool fatal) {
  v1::ServerMessage m;
  v1::Error* e = m.mutable_error();
  e->set_code(code);
  e->set_reason(reason);
  e->set_fatal(fatal);
  return frame_of(m);
}

using wire::to_proto;

std::shared_ptr<const std::string> welcome_frame(std::uint64_t client_id, v1::Role role,
                                                 const std::string& server_name, double rate_hz,
                                                 std::int64_t now_ns) {
  v1::ServerMessage m;
  v1::Welcome* w = m.mutable_welcome();
  w->set_protocol_version(kProtocolVersion);
  w->set_client_id(client_id);
  w->set_role(role);
  w->set_server_name(server_name);
  w->set_tick_rate_hz(rate_hz);
  w->set_server_time_ns(now_ns);
  return frame_of(m);
}

std::shared_ptr<const std::string> pong_frame(const v1::Ping& ping, std::int64_t now_ns) {
  v1::ServerMessage m;
  v1::Pong* p = m.mutable_pong();
  p->set_id(ping.id());
  p->set_client_time_ns(ping.client_time_ns());
  p->set_server_time_ns(now_ns);
  return frame_of(m);
}

void fill_frame(const rt::Snapshot& snapshot, bool contacts, v1::HapticFrame* out) {
  const rt::TickRecord& t = snapshot.tick;
  out->set_seq(t.seq);
  out->set_server_time_ns(t.t_ns);
  to_proto(t.pose, out->mutable_device_pose());
  to_proto(t.force, out->mutable_force());
  to_proto(t.torque, out->mutable_torque());
  to_proto(t.u, out->mutable_displacement());
  out->set_n_contact(static_cast<std::uint32_t>(t.n_contact));
  out->set_tick_status(t.tick_status);
  out->set_safety_status(t.safety_status);
  out->set_fault(t.fault);
  out->set_contact_points(snapshot.contact_points);
  out->set_device_state(to_proto(snapshot.device_state));
  out->set_pulse_wave(snapshot.pulse_wave);
  out->set_pulse_force(snapshot.pulse_force_N);
  out->set_organ_force(snapshot.organ_force_N);
  out->set_pulse_bpm(snapshot.pulse_bpm);
  if (!contacts) return;
  for (std::uint32_t i = 0; i < snapshot.contact_count; ++i) {
    const rt::ContactSnapshot& c = snapshot.contacts[i];
    v1::Contact* pc = out->add_contacts();
    to_proto(c.x, pc->mutable_position());
    to_proto(c.s, pc->mutable_surface());
    to_proto(c.p, pc->mutable_proxy());
    pc->set_in_contact(c.in_contact != 0);
    to_proto(c.f, pc->mutable_force());
  }
}

namespace {

ClientCheck bad(v1::Error::Code code, std::string reason) {
  return {false, code, std::move(reason)};
}

bool finite(const v1::Vec3& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

bool usable_pose(const v1::Pose& pose) {
  if (!finite(pose.position())) return false;
  if (!pose.has_orientation()) return true;
  const v1::Quat& q = pose.orientation();
  const double n2 = q.w() * q.w() + q.x() * q.x() + q.y() * q.y() + q.z() * q.z();
  return std::isfinite(n2) && n2 >= 0.25 && n2 <= 4.0;
}

}  // namespace

ClientCheck parse_client_message(std::string_view body, v1::ClientMessage& out) {
  out.Clear();
  if (!out.ParseFromArray(body.data(), static_cast<int>(body.size())))
    return bad(v1::Error::MALFORMED, "undecodable ClientMessage");
  switch (out.msg_case()) {
    case v1::ClientMessage::kHello: {
      const v1::Hello& h = out.hello();
      if (h.client_name().size() > kMaxNameBytes || h.token().size() > kMaxNameBytes)
        return bad(v1::Error::BAD_REQUEST, "client_name or token too long");
      if (!std::isfinite(h.frame_rate_hz()) || h.frame_rate_hz() < 0.0)
        return bad(v1::Error::BAD_REQUEST, "frame_rate_hz must be finite and >= 0");
      if (h.role() != v1::OBSERVER && h.role() != v1::CONTROLLER)
        return bad(v1::Error::BAD_REQUEST, "role must be OBSERVER or CONTROLLER");
      return {};
    }
    case v1::ClientMessage::kPing:
      return {};
    case v1::ClientMessage::kCommand: {
      const v1::Command& c = out.command();
      switch (c.kind_case()) {
        case v1::Command::kSetTool:
          if (c.set_tool().tool().size() > kMaxNameBytes)
            return bad(v1::Error::BAD_REQUEST, "tool name too long");
          return {};
        case v1::Command::kSetParameter:
          if (c.set_parameter().name().size() > kMaxNameBytes)
            return bad(v1::Error::BAD_REQUEST, "parameter name too long");
          if (!std::isfinite(c.set_parameter().value()))
            return bad(v1::Error::BAD_REQUEST, "parameter value must be finite");
          return {};
        case v1::Command::kStartRecording:
          if (c.start_recording().name().size() > kMaxNameBytes)
            return bad(v1::Error::BAD_REQUEST, "recording name too long");
          return {};
        case v1::Command::kTaskStart: {
          const v1::TaskStart& t = c.task_start();
          if (t.kind().size() > kMaxNameBytes || t.side().size() > kMaxNameBytes ||
              t.interspace().size() > kMaxNameBytes)
            return bad(v1::Error::BAD_REQUEST, "task kind, side or interspace too long");
          return {};
        }
        case v1::Command::kPause:
        case v1::Command::kRecentre:
        case v1::Command::kStopRecording:
        case v1::Command::kTaskMark:
        case v1::Command::kTaskNextTrial:
        case v1::Command::kTaskStop:
          return {};
        case v1::Command::KIND_NOT_SET:
          break;
      }
      return bad(v1::Error::BAD_REQUEST, "empty Command");
    }
    case v1::ClientMessage::kDevicePose:
      if (!usable_pose(out.device_pose().pose()))
        return bad(v1::Error::BAD_REQUEST, "device pose not finite or not a rotation");
      return {};
    case v1::ClientMessage::MSG_NOT_SET:
      break;
  }
  return bad(v1::Error::MALFORMED, "empty ClientMessage");
}

}  // namespace palp::net
