// The lab deployment files in deploy/: palpd accepts the example config as is, the systemd unit
// passes `systemd-analyze verify` (when installed) and keeps what the real-time loop needs, the
// udev rules are well formed and cover every device ID, the lab launcher prints the expected
// commands in --dry-run and really starts and stops a server and observers (a stub palpview and
// a stand-in ssh), and install-lab.sh lists its files in --dry-run and installs idempotently
// into a staging directory.
//
// Data flow: the files are read from the source tree (PALP_SOURCE_DIR, set by
// tests/CMakeLists.txt); palp comes from PALP_CLI_PATH and palpd from the same build directory
// (BUILD/server/palpd); the scripts run through /bin/sh with their output captured.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <toml++/toml.h>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support/cli_test_util.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::CliOutcome;
using testing::read_text;
using testing::shared_cli_dir;

const fs::path kSourceDir = fs::path(PALP_SOURCE_DIR);
const fs::path kBuildDir = fs::path(PALP_CLI_PATH).parent_path().parent_path();
const fs::path kPalpd = kBuildDir / "server" / "palpd";

std::string quoted(const fs::path& path) {
  std::string text(1, '\'');  // (not "'" + ...: g++ 12 then warns -Wrestrict, falsely)
  text += path.string();
  text += '\'';
  return text;
}

// Runs a shell command line, stderr with stdout.
CliOutcome run_shell(const std::string& command) {
  return palp::testing::run_command(command + " 2>&1 </dev/null");
}

bool have_program(const std::string& name) {
  return run_shell("command -v " + name + " >/dev/null").exit_code == 0;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

bool has_line(const std::string& text, const std::string& line) {
  for (const std::string& l : lines_of(text))
    if (l == line) return true;
  return false;
}

void write_file(const fs::path& path, const std::string& text, bool executable = false) {
  fs::create_directories(path.parent_path());
  std::ofstream(path) << text;
  if (executable)
    fs::permissions(path, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec,
                    fs::perm_options::replace);
}

// A fresh directory for one test.
fs::path test_dir(const std::string& name) {
  const fs::path dir = shared_cli_dir() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A TCP port that was free a moment ago (bound to port 0, then closed).
int free_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof address;
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) == 0)
    port = ntohs(address.sin_port);
  close(fd);
  return port;
}

// The value of `Key=` in a systemd unit (the last one), or "" when absent.
std::string unit_value(const std::string& unit, const std::string& key) {
  std::string value;
  for (const std::string& line : lines_of(unit))
    if (line.rfind(key + "=", 0) == 0) value = line.substr(key.size() + 1);
  return value;
}

// ------------------------------------------------------------------------------ palpd.toml

TEST(Deploy, PalpdAcceptsTheExampleConfig) {
  if (!fs::exists(kPalpd)) GTEST_SKIP() << kPalpd << " not built (ninja palpd)";
  const fs::path dir = test_dir("config");
  const std::string palpd =
      quoted(kPalpd) + " --config " + quoted(kSourceDir / "deploy/palpd.toml");
  const std::string session =
      " --scene phantom:sphere --device sim --port 0 --bind 127.0.0.1"
      " --duration 1 --no-realtime --cache-dir " +
      quoted(dir / "cache");
  const CliOutcome run = run_shell(palpd + session);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  // The lab's config never switches the force limits off (palpd refuses the key anyway).
  EXPECT_EQ(read_text(kSourceDir / "deploy/palpd.toml").find("no-force-limits ="),
            std::string::npos);
  EXPECT_NE(run.output.find("listening on 127.0.0.1:"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find(" ticks, "), std::string::npos) << run.output;
  // The file is really read: the same file with one unknown key is refused.
  write_file(dir / "bad.toml", read_text(kSourceDir / "deploy/palpd.toml") + "bogus-key = 1\n");
  const CliOutcome bad =
      run_shell(quoted(kPalpd) + " --config " + quoted(dir / "bad.toml") + session);
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("key 'bogus-key': unknown key"), std::string::npos) << bad.output;
}

// With its own device (usb-haptic, normally not plugged in where tests run) palpd keeps running:
// zero force, device absent. Needs a palpd that knows usb-haptic and a machine with usbfs.
TEST(Deploy, PalpdRunsTheExampleConfigWithoutItsDevice) {
  if (!fs::exists(kPalpd)) GTEST_SKIP() << kPalpd << " not built (ninja palpd)";
  if (run_shell(quoted(kPalpd) + " --help").output.find("usb-haptic") == std::string::npos)
    GTEST_SKIP() << "this palpd has no usb-haptic device";
  if (!fs::exists("/dev/bus/usb")) GTEST_SKIP() << "no usbfs on this machine";
  const fs::path dir = test_dir("config-usb");
  const CliOutcome run = run_shell(
      quoted(kPalpd) + " --config " + quoted(kSourceDir / "deploy/palpd.toml") +
      " --scene phantom:sphere --port 0 --bind 127.0.0.1 --duration 1 --no-realtime --cache-dir " +
      quoted(dir / "cache"));
  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("device usb-haptic"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find(" ticks, "), std::string::npos) << run.output;
}

TEST(Deploy, ConfigAndUnitAgree) {
  const toml::table config = toml::parse_file((kSourceDir / "deploy/palpd.toml").string());
  const std::string unit = read_text(kSourceDir / "deploy/systemd/palpd.service");
  // The loop's SCHED_FIFO priority is within the unit's LimitRTPRIO.
  const auto priority = config["priority"].value<std::int64_t>();
  ASSERT_TRUE(priority.has_value());
  EXPECT_LE(*priority, std::stoi(unit_value(unit, "LimitRTPRIO")));
  EXPECT_EQ(config["realtime"].value<bool>(), std::optional<bool>(true));
  // The token line install-lab.sh fills in is there, commented out.
  EXPECT_NE(read_text(kSourceDir / "deploy/palpd.toml").find("\n# token = \"CHANGE-ME\"\n"),
            std::string::npos);
}

// ------------------------------------------------------------------------------ systemd unit

TEST(Deploy, SystemdUnitKeepsWhatTheLoopNeeds) {
  const std::string unit = read_text(kSourceDir / "deploy/systemd/palpd.service");
  EXPECT_EQ(unit_value(unit, "ExecStart"), "/usr/local/bin/palpd --config /etc/palp/palpd.toml");
  EXPECT_EQ(unit_value(unit, "User"), "palp");
  EXPECT_EQ(unit_value(unit, "Group"), "palp");
  EXPECT_EQ(unit_value(unit, "Restart"), "on-failure");
  EXPECT_EQ(unit_value(unit, "LimitMEMLOCK"), "infinity");
  EXPECT_GE(std::stoi(unit_value(unit, "LimitRTPRIO")), 80);  // palpd's default --priority
  // Options that would break SCHED_FIFO, mlockall or the USB device are absent.
  EXPECT_EQ(unit_value(unit, "RestrictRealtime"), "");
  EXPECT_EQ(unit_value(unit, "PrivateDevices"), "");
  EXPECT_EQ(unit_value(unit, "PrivateUsers"), "");
  EXPECT_NE(unit_value(unit, "DeviceAllow").find("char-usb_device rw"), std::string::npos);
  EXPECT_NE(unit_value(unit, "RestrictAddressFamilies").find("AF_NETLINK"), std::string::npos);
  EXPECT_EQ(unit_value(unit, "NoNewPrivileges"), "yes");
  EXPECT_EQ(unit_value(unit, "CapabilityBoundingSet"), "");
}

TEST(Deploy, SystemdUnitVerifies) {
  if (!have_program("systemd-analyze")) GTEST_SKIP() << "systemd-analyze not installed";
  // verify checks that ExecStart's binary exists: point it at the built palpd (or /bin/true).
  const fs::path dir = test_dir("unit");
  const std::string binary = fs::exists(kPalpd) ? kPalpd.string() : "/bin/true";
  std::string unit = read_text(kSourceDir / "deploy/systemd/palpd.service");
  unit = std::regex_replace(unit, std::regex("/usr/local/bin/palpd"), binary);
  write_file(dir / "palpd.service", unit);
  const CliOutcome verify = run_shell("systemd-analyze verify " + quoted(dir / "palpd.service"));
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  // Unknown keys and bad values are only warnings ("palpd.service:LINE: ..."): none allowed.
  EXPECT_EQ(verify.output.find("palpd.service:"), std::string::npos) << verify.output;
  // The check itself catches a misspelt key.
  write_file(dir / "bad" / "palpd.service",
             std::regex_replace(unit, std::regex("LimitRTPRIO="), "LimitRTPRI0="));
  const CliOutcome bad = run_shell("systemd-analyze verify " + quoted(dir / "bad/palpd.service"));
  EXPECT_NE(bad.output.find("palpd.service:"), std::string::npos) << bad.output;
}

// ------------------------------------------------------------------------------ udev rules

TEST(Deploy, UdevRulesAreWellFormedAndCoverEveryDevice) {
  const std::string rules = read_text(kSourceDir / "deploy/udev/70-palp.rules");
  ASSERT_FALSE(rules.empty());
  const std::regex token(R"re(\s*([A-Z_]+(\{[A-Za-z0-9_/]+\})?)\s*(==|!=|\+=|=)\s*"([^"]*)"\s*)re");
  const std::set<std::string> match_keys = {"ACTION", "SUBSYSTEM", "ENV", "ATTR", "TEST"};
  const std::set<std::string> assign_keys = {"ENV", "ATTR", "MODE", "GROUP", "TAG", "GOTO"};
  std::set<std::string> gotos, labels;
  std::map<std::string, std::string> device_of;  // "vvvv:pppp" -> ID_PALP_DEVICE
  bool access_line = false;
  int line_number = 0;
  for (const std::string& line : lines_of(rules)) {
    ++line_number;
    if (line.empty() || line[0] == '#') continue;
    SCOPED_TRACE("line " + std::to_string(line_number) + ": " + line);
    std::map<std::string, std::string> fields;  // "KEY op" -> value
    std::string rest = line;
    int matches = 0;
    while (!rest.empty()) {
      std::smatch m;
      const std::string::size_type comma = rest.find("\",");
      const std::string part = comma == std::string::npos ? rest : rest.substr(0, comma + 1);
      ASSERT_TRUE(std::regex_match(part, m, token)) << "not KEY op \"value\": " << part;
      const std::string key = m[1], base = key.substr(0, key.find('{')), op = m[3];
      const bool is_match = op == "==" || op == "!=";
      EXPECT_TRUE(is_match ? match_keys.count(base) != 0
                           : assign_keys.count(base) != 0 || base == "LABEL")
          << key << op;
      matches += is_match;
      fields[key + op] = m[4];
      if (base == "GOTO") gotos.insert(m[4]);
      if (base == "LABEL") labels.insert(m[4]);
      rest = comma == std::string::npos ? "" : rest.substr(comma + 2);
    }
    if (fields.count("LABEL=") == 0) {
      EXPECT_GT(matches, 0) << "a rule without a match key";
    }
    if (fields.count("ATTR{idVendor}==")) {
      const std::string id = fields["ATTR{idVendor}=="] + ":" + fields["ATTR{idProduct}=="];
      EXPECT_EQ(device_of.count(id), 0u) << id << " listed twice";
      device_of[id] = fields["ENV{ID_PALP_DEVICE}="];
    }
    if (fields["MODE="] == "0660" && fields["GROUP="] == "palp" && fields["TAG+="] == "uaccess" &&
        fields["ENV{ID_PALP_DEVICE}=="] == "?*")
      access_line = true;
  }
  EXPECT_EQ(gotos, labels);
  EXPECT_TRUE(access_line) << "no MODE=0660 GROUP=palp TAG+=uaccess rule for the devices";
  std::map<std::string, std::string> expected = {{"1209:0001", "usb-haptic"},
                                                  {"0403:cb48", "falcon"}};
  for (const char* pid :
       {"c603", "c605", "c606", "c621", "c623", "c625", "c626", "c627", "c628", "c629", "c62b"})
    expected[std::string("046d:") + pid] = "spacemouse";
  for (const char* pid : {"c62e", "c62f", "c631", "c632", "c633", "c635", "c652"})
    expected[std::string("256f:") + pid] = "spacemouse";
  EXPECT_EQ(device_of, expected);
  // Where udev itself can check the file (systemd >= 254), it must agree.
  if (have_program("udevadm") && run_shell("udevadm verify --help >/dev/null").exit_code == 0) {
    const CliOutcome verify =
        run_shell("udevadm verify " + quoted(kSourceDir / "deploy/udev/70-palp.rules"));
    EXPECT_EQ(verify.exit_code, 0) << verify.output;
  }
}

// ------------------------------------------------------------------------------ lab.sh

TEST(Deploy, LabDryRunPrintsEveryCommand) {
  const CliOutcome run = run_shell(quoted(kSourceDir / "deploy/lab.sh") + " --dry-run " +
                                   quoted(kSourceDir / "deploy/lab.example.toml"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::string ssh = "+ ssh -o BatchMode=yes -o ConnectTimeout=10 -n -- ";
  for (const std::string& line : {
           std::string("+ palpd --config /etc/palp/palpd.toml --port 7400 --device usb-haptic"),
           std::string("+ palp probe 127.0.0.1:7400 --duration 1 -q --name palp-lab-probe"),
           std::string("+ env DISPLAY=:0 palpview --connect 127.0.0.1:7400 --name bedside "
                       "--observer --camera 30,20,600 --preset skin"),
           ssh + "observer1.lab 'echo PALP_PID=$$; exec env DISPLAY=:0 "
                 "XAUTHORITY=/home/lab/.Xauthority palpview --connect palp-server.lab:7400 "
                 "--name wall --observer --camera -60,35,700 --preset bone --width 1920 "
                 "--height 1080'",
           ssh + "observer2.lab 'echo PALP_PID=$$; exec env DISPLAY=:0.1 palpview --connect "
                 "palp-server.lab:7400 --name students --observer --camera 90,10,650 --preset "
                 "soft --rate 60'",
       })
    EXPECT_TRUE(has_line(run.output, line)) << "missing: " << line << "\nin:\n" << run.output;
  // One command line per observer of the file (read with a real TOML parser), plus palpd and
  // the probe; nothing else is run.
  const toml::table lab = toml::parse_file((kSourceDir / "deploy/lab.example.toml").string());
  const toml::array* observers = lab["observer"].as_array();
  ASSERT_NE(observers, nullptr);
  int commands = 0;
  for (const std::string& line : lines_of(run.output)) commands += line.rfind("+ ", 0) == 0;
  EXPECT_EQ(commands, static_cast<int>(observers->size()) + 2);
}

TEST(Deploy, LabRejectsBadFiles) {
  const fs::path dir = test_dir("labbad");
  const std::string lab = quoted(kSourceDir / "deploy/lab.sh") + " --dry-run ";
  write_file(dir / "syntax.toml", "[server]\nport = 7400 extra\n");
  CliOutcome run = run_shell(lab + quoted(dir / "syntax.toml"));
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("syntax.toml:2: unexpected text"), std::string::npos) << run.output;
  write_file(dir / "key.toml", "[[observer]]\nscreen = \":0\"\n");
  run = run_shell(lab + quoted(dir / "key.toml"));
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("unknown key 'screen' in [observer]"), std::string::npos) << run.output;
  run = run_shell(lab + quoted(dir / "absent.toml"));
  EXPECT_EQ(run.exit_code, 2) << run.output;
  run = run_shell(quoted(kSourceDir / "deploy/lab.sh") + " --help");
  EXPECT_EQ(run.exit_code, 0);
  EXPECT_NE(run.output.find("LABFILE"), std::string::npos);
}

// The launcher for real: palpd (sim device) here, one local observer and one "remote" one
// through a stand-in ssh that runs the command locally; both observers are a stub palpview that
// logs its arguments and answers SIGTERM. --duration stops everything: observers, then palpd.
TEST(Deploy, LabStartsAndStopsServerAndObservers) {
  if (!fs::exists(kPalpd)) GTEST_SKIP() << kPalpd << " not built (ninja palpd)";
  const fs::path dir = test_dir("labrun");
  write_file(dir / "palpview",
             "#!/bin/sh\necho \"stub palpview $*\"\necho \"DISPLAY=$DISPLAY\"\n"
             "trap 'echo stub stopped; exit 0' TERM\nwhile :; do sleep 0.1; done\n",
             true);
  // ssh [options] -n -- HOST COMMAND: runs COMMAND here.
  write_file(dir / "fake-ssh",
             "#!/bin/sh\nwhile [ \"$1\" != -- ]; do shift; done\nshift 2\nexec /bin/sh -c \"$*\"\n",
             true);
  const int port = free_port();
  ASSERT_GT(port, 0);
  write_file(dir / "lab.toml", "[lab]\npalp = \"" + std::string(PALP_CLI_PATH) + "\"\nssh = [\"" +
                                   (dir / "fake-ssh").string() +
                                   "\", \"-o\", \"BatchMode=yes\"]\nwait_s = 300\n"
                                   "[server]\npalpd = \"" +
                                   kPalpd.string() + "\"\naddress = \"lab-server.invalid\"\n" +
                                   "port = " + std::to_string(port) +
                                   "\noptions = [\"--scene\", \"phantom:sphere\", \"--device\", "
                                   "\"sim\", \"--no-realtime\", \"--cache-dir\", \"" +
                                   (dir / "cache").string() +
                                   "\"]\n"
                                   "[[observer]]\nname = \"near\"\ndisplay = \":5\"\n"
                                   "camera = \"-60,35,700\"\npalpview = \"" +
                                   (dir / "palpview").string() +
                                   "\"\n[[observer]]\nname = \"far\"\nhost = \"far.invalid\"\n"
                                   "preset = \"bone\"\npalpview = \"" +
                                   (dir / "palpview").string() + "\"\n");
  const CliOutcome run =
      run_shell(quoted(kSourceDir / "deploy/lab.sh") + " --duration 2 --log-dir " +
                quoted(dir / "logs") + " " + quoted(dir / "lab.toml"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("palpd answers: {\"ok\":true"), std::string::npos) << run.output;
  const std::string palpd_log = read_text(dir / "logs/palpd.log");
  EXPECT_NE(palpd_log.find(" ticks, "), std::string::npos) << palpd_log;  // stopped cleanly
  EXPECT_NE(palpd_log.find("(signal)"), std::string::npos) << palpd_log;
  const std::string near = read_text(dir / "logs/observer-near.log");
  EXPECT_NE(near.find("stub palpview --connect 127.0.0.1:" + std::to_string(port) +
                      " --name near --observer --camera -60,35,700\n"),
            std::string::npos)
      << near;
  EXPECT_NE(near.find("DISPLAY=:5\n"), std::string::npos) << near;
  EXPECT_NE(near.find("stub stopped"), std::string::npos) << near;
  const std::string far = read_text(dir / "logs/observer-far.log");
  EXPECT_TRUE(std::regex_search(far, std::regex("\nPALP_PID=[0-9]+\n"))) << far;
  EXPECT_NE(far.find("stub palpview --connect lab-server.invalid:" + std::to_string(port) +
                     " --name far --observer --preset bone\n"),
            std::string::npos)
      << far;
  EXPECT_NE(far.find("DISPLAY=:0\n"), std::string::npos) << far;
  EXPECT_NE(far.find("stub stopped"), std::string::npos) << far;
}

TEST(Deploy, LabFailsWhenPalpdDoesNotComeUp) {
  const fs::path dir = test_dir("labfail");
  write_file(dir / "lab.toml", "[lab]\npalp = \"" + std::string(PALP_CLI_PATH) +
                                   "\"\n[server]\npalpd = \"/bin/false\"\nport = 9\n");
  const CliOutcome run = run_shell(quoted(kSourceDir / "deploy/lab.sh") + " --wait 30 --log-dir " +
                                   quoted(dir / "logs") + " " + quoted(dir / "lab.toml"));
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("palpd exited before answering"), std::string::npos) << run.output;
}

TEST(Deploy, LabRefusesWhenAnotherServerHoldsThePort) {
  if (!fs::exists(kPalpd)) GTEST_SKIP() << kPalpd << " not built (ninja palpd)";
  const fs::path dir = test_dir("labforeign");
  const fs::path log = dir / "foreign.log";
  const CliOutcome started = run_shell(
      quoted(kPalpd) + " --scene phantom:cube --device sim --no-realtime --port 0 --duration 120" +
      " --cache-dir " + quoted(dir / "cache") + " >" + quoted(log) + " 2>&1 </dev/null & echo $!");
  ASSERT_EQ(started.exit_code, 0) << started.output;
  const std::string pid = started.output.substr(0, started.output.find('\n'));
  const std::regex listening("listening on 127\\.0\\.0\\.1:([0-9]+)");
  std::smatch match;
  std::string text;
  for (int i = 0; i < 600 && !std::regex_search(text, match, listening); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    text = read_text(log);
  }
  ASSERT_TRUE(std::regex_search(text, match, listening)) << text;
  write_file(dir / "lab.toml", "[lab]\npalp = \"" + std::string(PALP_CLI_PATH) +
                                   "\"\n[server]\npalpd = \"" + kPalpd.string() +
                                   "\"\nport = " + match[1].str() +
                                   "\noptions = [\"--scene\", \"phantom:cube\", \"--device\", "
                                   "\"sim\", \"--no-realtime\"]\n");
  const CliOutcome run = run_shell(quoted(kSourceDir / "deploy/lab.sh") + " --wait 30 --log-dir " +
                                   quoted(dir / "logs") + " " + quoted(dir / "lab.toml"));
  run_shell("kill -TERM " + pid);
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find("a server already answers at 127.0.0.1:" + match[1].str()),
            std::string::npos)
      << run.output;
  EXPECT_EQ(run.output.find("palpd answers"), std::string::npos) << run.output;
}

// ------------------------------------------------------------------------------ install-lab.sh

TEST(Deploy, InstallDryRunListsEverything) {
  const fs::path prefix = shared_cli_dir() / "dry-prefix";
  const CliOutcome run =
      run_shell(quoted(kSourceDir / "deploy/install-lab.sh") + " --dry-run --prefix " +
                quoted(prefix) + " --build-dir " + quoted(kBuildDir));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::string p = prefix.string();
  for (const std::string& target :
       {p + "/bin/palp", p + "/bin/palpd", p + "/bin/palp-lab", p + "/share/palp/lab.example.toml",
        p + "/share/doc/palp/operations.md", std::string("/etc/udev/rules.d/70-palp.rules"),
        std::string("/etc/systemd/system/palpd.service"),
        std::string("/etc/security/limits.d/palp.conf"), std::string("/etc/palp/palpd.toml")})
    EXPECT_TRUE(std::regex_search(
        run.output, std::regex("(-> |unchanged: |kept: |missing: .*-> )" + target + "( |\n)")))
        << "not listed: " << target << "\n"
        << run.output;
  EXPECT_NE(run.output.find("dry run: nothing was changed"), std::string::npos);
  EXPECT_FALSE(fs::exists(prefix));
}

TEST(Deploy, InstallIntoAStagingDirectoryIsIdempotent) {
  if (!fs::exists(kPalpd)) GTEST_SKIP() << kPalpd << " not built (ninja palpd)";
  const fs::path stage = test_dir("stage");
  const std::string install = quoted(kSourceDir / "deploy/install-lab.sh") + " --destdir " +
                              quoted(stage) + " --prefix /opt/palp --build-dir " +
                              quoted(kBuildDir);
  const CliOutcome first = run_shell(install);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_EQ(read_text(stage / "opt/palp/bin/palpd"), read_text(kPalpd));
  EXPECT_EQ(fs::status(stage / "opt/palp/bin/palp-lab").permissions() & fs::perms::owner_exec,
            fs::perms::owner_exec);
  const std::string unit = read_text(stage / "etc/systemd/system/palpd.service");
  EXPECT_EQ(unit_value(unit, "ExecStart"), "/opt/palp/bin/palpd --config /etc/palp/palpd.toml");
  const std::string config = read_text(stage / "etc/palp/palpd.toml");
  std::smatch token;
  ASSERT_TRUE(std::regex_search(config, token, std::regex("\ntoken = \"([0-9a-f]{32})\"\n")))
      << config;
  EXPECT_EQ(fs::status(stage / "etc/palp/palpd.toml").permissions() & fs::perms::others_all,
            fs::perms::none);
  EXPECT_EQ(read_text(stage / "etc/udev/rules.d/70-palp.rules"),
            read_text(kSourceDir / "deploy/udev/70-palp.rules"));
  EXPECT_NE(read_text(stage / "etc/security/limits.d/palp.conf").find("@palp - rtprio 90"),
            std::string::npos);
  // The installed config is one palpd accepts.
  const CliOutcome palpd =
      run_shell(quoted(kPalpd) + " --config " + quoted(stage / "etc/palp/palpd.toml") +
                " --scene phantom:sphere --device sim --port 0 --bind 127.0.0.1 --duration 0.2"
                " --no-realtime --cache-dir " +
                quoted(stage / "cache"));
  EXPECT_EQ(palpd.exit_code, 0) << palpd.output;

  const CliOutcome second = run_shell(install);
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_EQ(second.output.find("install: "), std::string::npos) << second.output;
  EXPECT_NE(second.output.find("everything was already installed"), std::string::npos);
  EXPECT_EQ(read_text(stage / "etc/palp/palpd.toml"), config);  // the token is kept
}

TEST(Deploy, ScriptsAreShellcheckClean) {
  if (!have_program("shellcheck")) GTEST_SKIP() << "shellcheck not installed";
  std::string command = "shellcheck";
  for (const char* script : {"deploy/lab.sh", "deploy/install-lab.sh", "deploy/make-certs.sh"}) {
    command += ' ';
    command += quoted(kSourceDir / script);
  }
  const CliOutcome run = run_shell(command);
  EXPECT_EQ(run.exit_code, 0) << run.output;
}

// ------------------------------------------------------------------------------ make-certs.sh
// A lab CA, palpd's certificate and a station's from the script; palpd with them in its config
// (the keys of palpd.toml's TLS section); palp probe and palp ctl over TLS, refused without it.
TEST(Deploy, MakeCertsGivesPalpdProbeAndCtlATlsSession) {
  if (!fs::exists(kPalpd)) GTEST_SKIP() << kPalpd << " not built (ninja palpd)";
  if (!have_program("openssl")) GTEST_SKIP() << "the openssl command is not installed";
  const fs::path dir = test_dir("tls");
  const std::string certs = quoted(kSourceDir / "deploy/make-certs.sh") + " " + quoted(dir / "pki");
  const CliOutcome made = run_shell(certs + " ca && " + certs + " server localhost 127.0.0.1 && " +
                                    certs + " client station-1");
  ASSERT_EQ(made.exit_code, 0) << made.output;
  EXPECT_EQ(fs::status(dir / "pki/server.key").permissions() & fs::perms::group_read,
            fs::perms::none);
  EXPECT_NE(run_shell(certs + " client station-1").exit_code, 0);  // never overwritten
  std::string config = read_text(kSourceDir / "deploy/palpd.toml");
  config += "tls-cert = '" + (dir / "pki/server.crt").string() + "'\n";
  config += "tls-key = '" + (dir / "pki/server.key").string() + "'\n";
  config += "tls-client-ca = '" + (dir / "pki/ca.crt").string() + "'\n";
  write_file(dir / "palpd.toml", config);
  const std::string palp = quoted(PALP_CLI_PATH);
  const std::string log = quoted(dir / "palpd.log");
  const std::string ca = " --tls-ca " + quoted(dir / "pki/ca.crt");
  std::string station = " --tls-cert " + quoted(dir / "pki/clients/station-1.crt");
  station += " --tls-key " + quoted(dir / "pki/clients/station-1.key");
  std::string script = quoted(kPalpd) + " --config " + quoted(dir / "palpd.toml");
  script += " --scene phantom:sphere --device sim --port 0 --bind 127.0.0.1 --duration 6";
  script += " --no-realtime --cache-dir " + quoted(dir / "cache") + " >" + log + " 2>&1 &\n";
  script +=
      "for i in $(seq 300); do grep -q 'listening on' " + log + " && break; sleep 0.1; done\n";
  script += "port=$(sed -n 's/.*listening on [^ ]*:\\([0-9]*\\),.*/\\1/p' " + log + " | head -1)\n";
  script += palp + " probe 127.0.0.1:$port --duration 1 -q" + ca + "; echo \"probe=$?\"\n";
  script += palp + " probe 127.0.0.1:$port --duration 1 -q; echo \"plain=$?\"\n";
  script += palp + " ctl 127.0.0.1:$port status" + ca + station + "; echo \"ctl=$?\"\n";
  script += palp + " ctl 127.0.0.1:$port status" + ca + "; echo \"nocert=$?\"\n";
  script += "wait; cat " + log;
  const CliOutcome run = run_shell(script);
  EXPECT_NE(run.output.find("probe=0"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("plain=1"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("over TLS only"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("ctl=0"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("nocert=1"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("none was presented"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("TLS 1.3 on: certificate CN=localhost"), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find("[CN=station-1,O=palp lab]"), std::string::npos) << run.output;
}

}  // namespace
}  // namespace palp
