// palp's DDS topics as a DDS tool that is not palp reads them: no palp type is compiled in here
// (no palp_types.h, no palp::dds). For each topic this test finds palpd's writer in the builtin
// DCPSPublication topic, takes the type information it announced, has Cyclone build the type
// from it (dds_create_topic_descriptor, asking palpd for the type objects), and reads samples
// with a reader of the writer's durability and reliability. The keys are read through the
// descriptor Cyclone built (its key list and marshalling ops), not through palp's layout.
//
// Cyclone DDS 0.10.2 (Debian 12) cannot build a type keyed on a bounded string: with
// `@key string<64> rig` dds_create_topic_descriptor returned Unsupported for scene, stats, volume
// and rigs (docs/dds.md).
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "dds/dds.h"
#include "dds/ddsc/dds_opcodes.h"
#include "support/cli_test_util.hpp"
#include "support/dds_loopback.hpp"
#include "support/palpd_process.hpp"

#if __has_include("palp_types.h")
#error "this test must not see palp's generated DDS types: it stands for a tool that is not palp"
#endif

namespace palp {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The value of each top-level key of `sample`, as text, found through `desc` alone: each key
// descriptor points at a KOF op naming the key member's ADR op, whose type and offset say where
// and how the value lies in the sample.
std::map<std::string, std::string> keys_of(const dds_topic_descriptor_t& desc, const void* sample) {
  std::map<std::string, std::string> out;
  const auto* base = static_cast<const char*>(sample);
  for (std::uint32_t i = 0; i < desc.m_nkeys; ++i) {
    const dds_key_descriptor_t& key = desc.m_keys[i];
    const std::uint32_t kof = desc.m_ops[key.m_offset];
    if (DDS_OP(kof) != DDS_OP_KOF || (kof & 0xffff) != 1) {
      out[key.m_name] = "<nested key>";
      continue;
    }
    const std::uint32_t adr = desc.m_ops[key.m_offset + 1];
    const std::uint32_t op = desc.m_ops[adr];
    const std::uint32_t offset = desc.m_ops[adr + 1];
    switch (DDS_OP_TYPE(op)) {
      case DDS_OP_VAL_STR: {
        const char* s = *reinterpret_cast<const char* const*>(base + offset);
        out[key.m_name] = s ? s : "";
        break;
      }
      case DDS_OP_VAL_BST:
        out[key.m_name] = base + offset;
        break;
      case DDS_OP_VAL_4BY: {
        std::uint32_t v = 0;
        std::memcpy(&v, base + offset, sizeof v);
        out[key.m_name] = std::to_string(v);
        break;
      }
      default:
        out[key.m_name] = "<type " + std::to_string(DDS_OP_TYPE(op)) + ">";
    }
  }
  return out;
}

struct TopicRead {
  std::string error;      // empty when the type was built and a reader made
  std::string type_name;  // as the writer announced it
  std::vector<std::string> key_names;
  std::vector<std::map<std::string, std::string>> samples;  // keys of each valid sample
};

// A participant that knows no types: everything it reads, it learns from discovery.
class DiscoveryOnlyReader {
 public:
  explicit DiscoveryOnlyReader(std::uint32_t domain)
      : participant_(dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr)),
        publications_(
            dds_create_reader(participant_, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr)) {}
  ~DiscoveryOnlyReader() {
    dds_delete(participant_);  // topics and readers first: then their descriptors can go
    for (dds_topic_descriptor_t* d : descriptors_) dds_delete_topic_descriptor(d);
  }
  DiscoveryOnlyReader(const DiscoveryOnlyReader&) = delete;
  DiscoveryOnlyReader& operator=(const DiscoveryOnlyReader&) = delete;
  bool ok() const { return participant_ > 0 && publications_ > 0; }

  // Finds a writer of `topic` (waiting up to `wait_s`), builds its type from the type
  // information it announced, and reads until `want` samples came or `wait_s` passed.
  TopicRead read(const std::string& topic, std::size_t want, double wait_s) {
    TopicRead r;
    const auto end = Clock::now() + std::chrono::duration<double>(wait_s);
    dds_topic_descriptor_t* desc = nullptr;
    dds_qos_t* qos = dds_create_qos();
    while (desc == nullptr && r.error.empty() && Clock::now() < end) {
      if (!describe(topic, wait_s, &desc, qos, &r))
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (desc == nullptr) {
      if (r.error.empty()) r.error = "no writer of " + topic + " discovered";
      dds_delete_qos(qos);
      return r;
    }
    descriptors_.push_back(desc);
    for (std::uint32_t i = 0; i < desc->m_nkeys; ++i) r.key_names.push_back(desc->m_keys[i].m_name);
    const dds_entity_t t = dds_create_topic(participant_, desc, topic.c_str(), nullptr, nullptr);
    const dds_entity_t reader = t > 0 ? dds_create_reader(participant_, t, qos, nullptr) : t;
    dds_delete_qos(qos);
    if (reader <= 0) {
      r.error = std::string("topic or reader: ") + dds_strretcode(reader);
      return r;
    }
    while (r.samples.size() < want && Clock::now() < end) {
      void* samples[16] = {};
      dds_sample_info_t infos[16];
      const dds_return_t n = dds_take(reader, samples, infos, 16, 16);
      for (dds_return_t i = 0; i < n; ++i)
        if (infos[i].valid_data) r.samples.push_back(keys_of(*desc, samples[i]));
      if (n > 0) dds_return_loan(reader, samples, n);
      if (n <= 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return r;
  }

 private:
  // One pass over the publications seen: when one is on `topic`, its type's descriptor (built
  // by Cyclone from the announced type information) and its durability and reliability in
  // `qos`. True when it found the writer (`*desc` null and r->error set when the type failed).
  bool describe(const std::string& topic, double wait_s, dds_topic_descriptor_t** desc,
                dds_qos_t* qos, TopicRead* r) {
    void* samples[64] = {};
    dds_sample_info_t infos[64];
    const dds_return_t n = dds_read(publications_, samples, infos, 64, 64);
    bool found = false;
    for (dds_return_t i = 0; i < n && !found; ++i) {
      auto* ep = static_cast<dds_builtintopic_endpoint_t*>(samples[i]);
      if (!infos[i].valid_data || topic != ep->topic_name) continue;
      found = true;
      r->type_name = ep->type_name;
      const dds_typeinfo_t* info = nullptr;
      if (dds_builtintopic_get_endpoint_type_info(ep, &info) != DDS_RETCODE_OK || !info) {
        r->error = "the writer announced no type information";
        break;
      }
      const dds_return_t rc = dds_create_topic_descriptor(DDS_FIND_SCOPE_GLOBAL, participant_, info,
                                                          DDS_SECS(static_cast<int>(wait_s)), desc);
      if (rc != DDS_RETCODE_OK) {
        *desc = nullptr;
        r->error = std::string("dds_create_topic_descriptor: ") + dds_strretcode(rc);
        break;
      }
      dds_durability_kind_t durability = DDS_DURABILITY_VOLATILE;
      dds_reliability_kind_t reliability = DDS_RELIABILITY_BEST_EFFORT;
      dds_duration_t blocking = 0;
      dds_qget_durability(ep->qos, &durability);
      dds_qget_reliability(ep->qos, &reliability, &blocking);
      dds_qset_durability(qos, durability);
      dds_qset_reliability(qos, reliability, blocking);
      dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 16);
    }
    if (n > 0) dds_return_loan(publications_, samples, n);
    return found;
  }

  dds_entity_t participant_;
  dds_entity_t publications_;
  std::vector<dds_topic_descriptor_t*> descriptors_;
};

class DdsDiscovery : public ::testing::Test {
 protected:
  void SetUp() override { testing::use_dds_loopback(); }
};

// Every topic palpd publishes with a native type, scene/stats/volume and the rig list included
// (the transient-local ones: their samples were written before this reader existed), and the
// ROS 2 topics under their ROS 2 names and type names.
TEST_F(DdsDiscovery, AToolWithoutPalpsTypesReadsEveryTopic) {
  const fs::path dir = fs::temp_directory_path() / ("palp_dds_disc" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::uint32_t domain = testing::unique_dds_domain();
  const int port =
      testing::start_palpd("--scene phantom:cube --device sim --port 0 --duration 15 --dds " +
                               std::to_string(domain) + " --rig disc --dds-volume-max-dim 16",
                           dir / "palpd.log");
  ASSERT_GT(port, 0) << testing::read_text(dir / "palpd.log");
  DiscoveryOnlyReader tool(domain);
  ASSERT_TRUE(tool.ok());

  struct Expect {
    std::string topic, type;
    std::vector<std::string> keys;
  };
  const std::vector<std::string> encoded_keys = {"rig", "index"};
  const Expect latched[] = {
      {"rt/palp/disc/scene", "palp::dds::Encoded", encoded_keys},
      {"rt/palp/disc/stats", "palp::dds::Encoded", encoded_keys},
      {"rt/palp/disc/volume", "palp::dds::Encoded", encoded_keys},
      {"rt/palp/rigs", "palp::dds::RigInfo", {"rig"}},
  };
  for (const Expect& e : latched) {
    const TopicRead r = tool.read(e.topic, 1, 10.0);
    ASSERT_EQ(r.error, "") << e.topic;
    EXPECT_EQ(r.type_name, e.type) << e.topic;
    EXPECT_EQ(r.key_names, e.keys) << e.topic;
    ASSERT_GE(r.samples.size(), 1u) << e.topic;
    for (const auto& keys : r.samples) EXPECT_EQ(keys.at("rig"), "disc") << e.topic;
    if (e.topic.ends_with("/scene")) {
      EXPECT_EQ(r.samples[0].at("index"), "0");
    }
  }
  const Expect streams[] = {
      {"rt/palp/disc/frames", "palp::dds::HapticFrame", {}},
      {"rt/palp/disc/frame_batch", "palp::dds::FrameBatch", {}},
      {"rt/palp/disc/tool_pose", "geometry_msgs::msg::dds_::PoseStamped_", {}},
      {"rt/palp/disc/wrench", "geometry_msgs::msg::dds_::WrenchStamped_", {}},
  };
  for (const Expect& e : streams) {
    const TopicRead r = tool.read(e.topic, 3, 10.0);
    ASSERT_EQ(r.error, "") << e.topic;
    EXPECT_EQ(r.type_name, e.type) << e.topic;
    EXPECT_TRUE(r.key_names.empty()) << e.topic;
    EXPECT_GE(r.samples.size(), 3u) << e.topic;
  }
  EXPECT_TRUE(testing::wait_palpd_exit(dir / "palpd.log"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace palp
