// palpview's command line without a display: defaults, what each option sets, and the mistakes
// refused before a window opens; the frame-time summary's quantiles.
#include "app/viewer_options.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "app/frame_times.hpp"
#include "base/errors.hpp"

namespace palp::view {
namespace {

std::optional<Options> parse(std::vector<std::string> args) {
  args.insert(args.begin(), "palpview");
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  return parse_options(static_cast<int>(argv.size()), argv.data());
}

std::string refusal(std::vector<std::string> args) {
  try {
    parse(std::move(args));
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(ViewerOptions, DefaultsFollowTheToolFromTheAnteriorSide) {
  const auto o = parse({"--connect", "127.0.0.1:7700"});
  ASSERT_TRUE(o);
  EXPECT_EQ(o->host, "127.0.0.1");
  EXPECT_EQ(o->port, 7700);
  EXPECT_FALSE(o->controller);
  EXPECT_EQ(o->view, Anatomy::Anterior);
  EXPECT_EQ(o->follow_mm, 150.0);  // --follow 150 unless --camera
  EXPECT_EQ(o->volume_max_dim, 256u);
  EXPECT_TRUE(o->ct);
  EXPECT_TRUE(o->deformation);
  EXPECT_EQ(o->chart_s, 30.0);
  EXPECT_FALSE(o->skin_hu);  // the skin preset on d_surf's zero level
}

TEST(ViewerOptions, SkinHuKeepsTheSkinPresetOnTheCtsHu) {
  const auto o = parse({"--connect", "h:1", "--skin-hu"});
  ASSERT_TRUE(o);
  EXPECT_TRUE(o->skin_hu);
  EXPECT_TRUE(o->ct);  // the HU are still asked for
}

TEST(ViewerOptions, ShowLandmarksAsksForThemFromTheStart) {
  const auto plain = parse({"--connect", "h:1"});
  ASSERT_TRUE(plain);
  EXPECT_FALSE(plain->show_landmarks);  // only key L shows them
  const auto o = parse({"--connect", "h:1", "--show-landmarks"});
  ASSERT_TRUE(o);
  EXPECT_TRUE(o->show_landmarks);
  EXPECT_NE(std::string(kUsage).find("--show-landmarks"), std::string::npos);
}

TEST(ViewerOptions, ACameraTurnsFollowingOffUnlessAsked) {
  auto o = parse({"--connect", "h:1", "--camera", "30,10,400"});
  ASSERT_TRUE(o);
  EXPECT_EQ(o->follow_mm, 0.0);
  EXPECT_EQ(o->az, 30.0);
  EXPECT_EQ(o->el, 10.0);
  EXPECT_EQ(o->dist, 400.0);
  o = parse({"--connect", "h:1", "--camera", "30,10,400", "--follow", "120"});
  ASSERT_TRUE(o);
  EXPECT_EQ(o->follow_mm, 120.0);
}

TEST(ViewerOptions, DdsWatchesARigOnADomainInsteadOfConnecting) {
  const auto o = parse({"--dds", "7", "--rig", "bay_2"});
  ASSERT_TRUE(o);
  EXPECT_TRUE(o->dds);
  EXPECT_EQ(o->dds_domain, 7u);
  EXPECT_EQ(o->dds_rig, "bay_2");
  const auto d = parse({"--dds"});
  ASSERT_TRUE(d);
  EXPECT_EQ(d->dds_domain, 0u);
  EXPECT_FALSE(d->dds_rig.empty());  // the host name, as palpd's default
}

TEST(ViewerOptions, HelpGivesNoOptionsAndTheUsageNamesEveryOption) {
  EXPECT_FALSE(parse({"--help"}));
  EXPECT_FALSE(parse({"-h"}));
  for (const char* option : {"--connect", "--controller", "--tls-ca", "--preset", "--follow",
                             "--chart-seconds", "--screenshot", "--stats-json"})
    EXPECT_NE(std::string(kUsage).find(option), std::string::npos) << option;
}

TEST(ViewerOptions, MistakesAreRefusedWithWhatIsWrong) {
  EXPECT_EQ(refusal({}), "--connect HOST:PORT is required (or --dds)");
  EXPECT_EQ(refusal({"--connect", "h:1", "--dds"}), "--connect and --dds: one or the other");
  EXPECT_EQ(refusal({"--connect", "h:1", "--rig", "a"}), "--rig needs --dds");
  EXPECT_EQ(refusal({"--connect", "h:1", "--frames", "3"}), "--frames needs --screenshot FILE");
  EXPECT_EQ(refusal({"--connect", "h:1", "--script", "a.csv"}), "--script needs --controller");
  EXPECT_EQ(refusal({"--connect", "h:1", "--rate", "-1"}), "--rate: 0 to 100000 Hz");
  EXPECT_NE(refusal({"--connect", "h:1", "--bogus"}), "");
  EXPECT_NE(refusal({"--connect", "h:1", "--preset", "lungs"}), "");
  EXPECT_NE(refusal({"--connect", "h:1", "--width"}), "");  // value missing
}

// A station's certificate without --tls-ca/--tls-pin would connect in plain text, the
// certificate never shown: refused as palp ctl and palp probe refuse it.
TEST(ViewerOptions, ACertificateWithoutTlsIsRefused) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--connect", "h:1", "--tls-cert", "s.crt", "--tls-key", "s.key"},
        std::vector<std::string>{"--connect", "h:1", "--controller", "--tls-cert", "s.crt",
                                 "--tls-key", "s.key", "--token", "t"},
        std::vector<std::string>{"--connect", "h:1", "--tls-key", "s.key"}}) {
    const std::string no = refusal(args);
    EXPECT_NE(no.find("--tls-ca FILE or --tls-pin SHA256"), std::string::npos) << no;
  }
  EXPECT_NE(refusal({"--connect", "h:1", "--tls-ca", "ca.crt", "--tls-cert", "s.crt"}), "");
  EXPECT_EQ(refusal({"--connect", "h:1", "--tls-ca", "ca.crt", "--tls-cert", "s.crt", "--tls-key",
                     "s.key"}),
            "");
}

TEST(FrameTimes, SummaryGivesMeanAndQuantilesOfTheSortedTimes) {
  std::vector<double> v;
  for (int i = 20; i >= 1; --i) v.push_back(i);  // 20 .. 1
  const nlohmann::json j = summary(v);
  EXPECT_EQ(j["n"], 20);
  EXPECT_EQ(j["mean"], 10.5);
  EXPECT_EQ(j["p50"], 11.0);  // element 10 of 1..20
  EXPECT_EQ(j["p95"], 20.0);  // element 19
  EXPECT_EQ(j["max"], 20.0);
  EXPECT_EQ(summary({})["n"], 0);
  EXPECT_FALSE(summary({}).contains("mean"));
  EXPECT_EQ(mean_of({}), 0.0);
  EXPECT_EQ(mean_of({1.0, 2.0}), 1.5);
}

}  // namespace
}  // namespace palp::view
