#include "dds_common.hpp"

#include <unistd.h>

#include <cctype>
#include <cstring>
#include <ctime>

#include "base/errors.hpp"

namespace palp::dds {

std::string topic_name(const std::string& rig, const char* leaf) {
  return "rt/palp/" + rig + "/" + leaf;
}

bool valid_rig(const std::string& rig) {
  if (rig.empty() || rig.size() > kMaxRigBytes) return false;
  if (std::isdigit(static_cast<unsigned char>(rig[0]))) return false;
  for (const char ch : rig)
    if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_')) return false;
  return true;
}

bool valid_rig(const char* rig) {
  if (rig == nullptr) return false;
  const std::size_t n = strnlen(rig, kMaxRigBytes + 1);
  return n <= kMaxRigBytes && valid_rig(std::string(rig, n));
}

bool same_rig(const char* received, const std::string& rig) {
  return valid_rig(received) && rig == received;
}

void check_rig(const std::string& rig) {
  if (!valid_rig(rig))
    throw UsageError("rig name '" + rig +
                     "': 1..63 letters, digits or '_', not starting with a digit");
}

std::string default_rig() {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0 || host[0] == '\0') return "palp";
  std::string rig;
  for (const char* p = host; *p && rig.size() < kMaxRigBytes; ++p)
    rig += std::isalnum(static_cast<unsigned char>(*p)) ? *p : '_';
  if (std::isdigit(static_cast<unsigned char>(rig[0]))) rig = ("h" + rig).substr(0, kMaxRigBytes);
  return valid_rig(rig) ? rig : "palp";
}

std::uint32_t parse_domain(const std::string& text) {
  std::uint32_t v = 0;
  bool ok = !text.empty() && text.size() <= 3;
  for (const char ch : text) {
    if (ch < '0' || ch > '9') ok = false;
    v = v * 10 + static_cast<std::uint32_t>(ch - '0');
  }
  if (!ok || v > 232) throw UsageError("DDS domain '" + text + "': an integer in 0..232");
  return v;
}

std::vector<std::string> split_dds_domain(std::vector<std::string> argv) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < argv.size(); ++i) {
    const std::string& a = argv[i];
    if (a.rfind("--dds=", 0) == 0) {
      out.push_back("--dds");
      out.push_back("--dds-domain=" + a.substr(6));
    } else if (a == "--dds" && i + 1 < argv.size() && !argv[i + 1].empty() &&
               std::isdigit(static_cast<unsigned char>(argv[i + 1][0]))) {
      out.push_back("--dds");
      out.push_back("--dds-domain=" + argv[++i]);
    } else {
      out.push_back(a);
    }
  }
  return out;
}

QosPtr make_qos(QosKind kind, std::int32_t depth) {
  QosPtr q(dds_create_qos());
  if (!q) throw ResourceError("DDS: no memory for a QoS");
  switch (kind) {
    case QosKind::Stream:
      dds_qset_reliability(q.get(), DDS_RELIABILITY_BEST_EFFORT, 0);
      dds_qset_history(q.get(), DDS_HISTORY_KEEP_LAST, depth);
      dds_qset_durability(q.get(), DDS_DURABILITY_VOLATILE);
      break;
    case QosKind::Latched:
      dds_qset_reliability(q.get(), DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
      dds_qset_history(q.get(), DDS_HISTORY_KEEP_LAST, depth);
      dds_qset_durability(q.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
      break;
    case QosKind::Command:
      dds_qset_reliability(q.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
      dds_qset_history(q.get(), DDS_HISTORY_KEEP_LAST, depth);
      dds_qset_durability(q.get(), DDS_DURABILITY_VOLATILE);
      break;
  }
  return q;
}

void Entity::reset() {
  if (handle_ > 0) dds_delete(handle_);
  handle_ = 0;
}

dds_entity_t checked(dds_entity_t result, const std::string& what) {
  if (result < 0) throw ResourceError("DDS: " + what + ": " + dds_strretcode(result));
  return result;
}

Entity make_participant(std::uint32_t domain) {
  return Entity(checked(
      dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr),
      "cannot join domain " + std::to_string(domain) + " (check CYCLONEDDS_URI and the network)"));
}

dds_entity_t make_topic(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                        const std::string& name) {
  return checked(dds_create_topic(participant, desc, name.c_str(), nullptr, nullptr),
                 "topic " + name);
}

std::int64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

builtin_interfaces_msg_dds__Time_ to_time(std::int64_t ns) {
  std::int64_t sec = ns / 1000000000, rem = ns % 1000000000;
  if (rem < 0) rem += 1000000000, --sec;
  return {static_cast<std::int32_t>(sec), static_cast<std::uint32_t>(rem)};
}

std::int64_t from_time(const builtin_interfaces_msg_dds__Time_& t) {
  return static_cast<std::int64_t>(t.sec) * 1000000000 + t.nanosec;
}

}  // namespace palp::dds
