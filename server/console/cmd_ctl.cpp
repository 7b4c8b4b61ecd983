// palp ctl HOST:PORT ACTION — a lab's console for a running palpd: connects as the controller,
// sends one action (a Command per change), prints what palpd answered and what changed, and
// exits non-zero when palpd refused anything or could not be reached.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "asio.hpp"
#include "base/errors.hpp"
#include "cli/commands.hpp"
#include "cli_common/cli.hpp"
#include "cli_common/config_file.hpp"
#include "cli_common/tls_options.hpp"
#include "client_core/host_port.hpp"
#include "client_core/server_link.hpp"
#include "console/ctl_task.hpp"
#include "scene/trajectory.hpp"
#include "wire/framing.hpp"

namespace palp::cli {
namespace {

constexpr const char* kCtlUsage = R"(usage: palp ctl HOST:PORT ACTION [options]

Runs one action on a running palpd as its controller (the one client that may change things), then
disconnects. palpd allows one controller at a time: ctl is refused while another (a palpview with
--role controller, or the remote device's driver) holds the role.
Actions:
  status                  the tool, the force model and its parameters, paused or not, the
                          recording, the rate, clients and faults
  record start [NAME]     start recording into palpd's --record-dir as NAME (a .rec and NAME's
                          .csv beside it; default trial-YYYYMMDD-HHMMSS); a name that exists is
                          refused, never overwritten
  record stop             stop the recording (its files are complete when this returns)
  set NAME=VALUE...       force parameters, one Command each, in order (palp run --help lists
                          them and their ranges); stops at the first refused
  pulse BPM               the arteries' heart rate, 0..240 beats per minute (0: no pulse);
                          the same as set pulse_bpm=BPM, applied between two ticks, contacts kept
  tool TOOL               finger:N, twofinger:N or probe:NXxNY
  pause | resume          zero force and the model held, or ticking again (force ramps back in)
  recentre                move the device's home to where it is now (usb-haptic, spacemouse)
  task start KIND [--side right|left] [--space N] [--interspace L3/L4|L4/L5]
                          start a training task (ptcd: the space below rib N, 9 by default, on
                          a side; lumbar: an interspace; femoral: the pulse on a side), trial 1
  task mark               mark the spot: the trainee's finger now (palpd scores it)
  task next               score this trial and start the next one
  task stop               score this trial, end the session and write its report
  task status             the task, the trial, its marks and the last mark's score, as the
                          instructor sees it (connects as an observer: no token needed)
Options:
  --token TOKEN           palpd's token (default: the 'token' key of --config); sent only over
                          TLS or loopback: to another machine without --tls-ca/--tls-pin ctl
                          refuses to connect
  --config FILE           palpd's config file, to read its token
  --name NAME             the name palpd logs for this client (default palp-ctl)
  --timeout S             seconds to wait for palpd's answers (default 5)
  --tls-ca FILE           palp.v1 over TLS: check the server's certificate against this CA and
                          the host name
  --tls-pin SHA256        or: trust exactly the server certificate with this SHA-256
                          fingerprint (openssl x509 -noout -fingerprint -sha256 -in CERT)
  --tls-cert FILE         this client's certificate (palpd --tls-client-ca asks controllers)
  --tls-key FILE          its key (mode 600)
  -h, --help              show this help
Each result is printed as "ok" or "refused: <palpd's reason>"; the exit code is 0 when everything
was done, 1 when palpd refused or could not be reached, 2 for a usage mistake.
)";

using asio::ip::tcp;

struct Action {
  std::vector<v1::Command> commands;
  std::vector<std::string> what;  // one line per command, for people
  bool status = false;
  bool task = false;      // a task action: the TaskStatus that follows is printed
  bool observer = false;  // task status: as an observer
};

// A number for `what` (a parameter's or the pulse's value); UsageError otherwise.
double action_number(const std::string& text, const std::string& what) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(value))
    throw UsageError("ctl " + what + " needs a number, got '" + text + "'");
  return value;
}

void add_parameter(Action& a, const std::string& name, double value, std::string what) {
  v1::Command c;
  c.mutable_set_parameter()->set_name(name);
  c.mutable_set_parameter()->set_value(value);
  a.commands.push_back(c);
  a.what.push_back(std::move(what));
}

// set NAME=VALUE...
void parse_set(const std::vector<std::string>& words, Action& a) {
  if (words.size() < 2) throw UsageError("ctl set needs NAME=VALUE");
  for (std::size_t i = 1; i < words.size(); ++i) {
    const std::string& w = words[i];
    const auto eq = w.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == w.size())
      throw UsageError("ctl set needs NAME=VALUE, got '" + w + "'");
    add_parameter(a, w.substr(0, eq), action_number(w.substr(eq + 1), "set " + w.substr(0, eq)),
                  "set " + w);
  }
}

Action parse_action(const std::vector<std::string>& words) {
  if (words.empty()) throw UsageError("ctl needs an ACTION (status, record, set, tool, ...)");
  Action a;
  const std::string& verb = words[0];
  const auto no_more = [&](std::size_t n) {
    if (words.size() > n) throw UsageError("ctl " + verb + ": unexpected '" + words[n] + "'");
  };
  if (verb == "status") {
    no_more(1);
    a.status = true;
  } else if (verb == "record") {
    if (words.size() < 2) throw UsageError("ctl record needs start [NAME] or stop");
    v1::Command c;
    if (words[1] == "start") {
      no_more(3);
      std::string name = words.size() > 2 ? words[2] : "";
      if (name.empty()) {
        const std::time_t now = std::time(nullptr);
        char text[64];
        std::strftime(text, sizeof text, "trial-%Y%m%d-%H%M%S", std::localtime(&now));
        name = text;
      }
      c.mutable_start_recording()->set_name(name);
      a.what.push_back("record start " + name);
    } else if (words[1] == "stop") {
      no_more(2);
      c.mutable_stop_recording();
      a.what.push_back("record stop");
    } else {
      throw UsageError("ctl record needs start [NAME] or stop, got '" + words[1] + "'");
    }
    a.commands.push_back(c);
  } else if (verb == "set") {
    parse_set(words, a);
  } else if (verb == "pulse") {
    if (words.size() != 2) throw UsageError("ctl pulse needs one BPM (0..240, 0: no pulse)");
    add_parameter(a, "pulse_bpm", action_number(words[1], "pulse"), "pulse " + words[1]);
  } else if (verb == "tool") {
    if (words.size() != 2) throw UsageError("ctl tool needs one TOOL");
    v1::Command c;
    c.mutable_set_tool()->set_tool(words[1]);
    a.commands.push_back(c);
    a.what.push_back("tool " + words[1]);
  } else if (verb == "pause" || verb == "resume") {
    no_more(1);
    v1::Command c;
    c.mutable_pause()->set_paused(verb == "pause");
    a.commands.push_back(c);
    a.what.push_back(verb);
  } else if (verb == "recentre" || verb == "recenter") {
    no_more(1);
    v1::Command c;
    c.mutable_recentre();
    a.commands.push_back(c);
    a.what.push_back("recentre");
  } else if (verb == "task") {
    CtlTaskAction t = parse_ctl_task(words);
    a.commands = std::move(t.commands);
    a.what = std::move(t.what);
    a.task = true;
    a.observer = t.observer;
  } else {
    throw UsageError("unknown ctl action '" + verb +
                     "' (status, record start|stop, set, pulse, tool, pause, resume, recentre, "
                     "task)");
  }
  for (std::size_t i = 0; i < a.commands.size(); ++i) a.commands[i].set_request_id(i + 1);
  return a;
}

// The session: Hello as controller, the commands one by one (each waits for its result), then
// the SceneInfo and Stats that follow, or the deadline.
class Session {
 public:
  Session(std::string host, std::string port, v1::Hello hello, Action action, double timeout_s,
          tls::ClientContext* tls)
      : host_(std::move(host)),
        port_(std::move(port)),
        hello_(std::move(hello)),
        action_(std::move(action)),
        timeout_(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
            std::chrono::duration<double>(timeout_s))),
        tls_(tls),
        link_(io_, "palpd",
              {nullptr, [this](const v1::ServerMessage& m) { handle(m); },
               [this](const std::string& why) { fail(why); }}) {}

  int run() {
    const auto endpoints =
        client::resolve_peer(io_, host_, port_, !hello_.token().empty(), tls_ != nullptr);
    tls::async_connect(link_.stream(), endpoints, host_, port_, tls_,
                       [this](const std::string& failure) {
                         if (!failure.empty()) return fail(failure);
                         v1::ClientMessage m;
                         *m.mutable_hello() = hello_;
                         send(m);
                         link_.read();
                       });
    io_.run_for(timeout_);
    if (!link_.closed()) {
      fail(welcomed_ ? "no answer from palpd within the timeout (--timeout)"
                     : "palpd did not welcome this client within the timeout");
    }
    return refused_ || !failure_.empty() ? 1 : 0;
  }

 private:
  void fail(const std::string& why) {
    if (failure_.empty()) {
      failure_ = why;
      std::fprintf(stderr, "palp ctl: %s\n", why.c_str());
    }
    finish();
  }
  void finish() {
    link_.close();
    io_.stop();
  }
  void send(const v1::ClientMessage& m) { link_.send(m); }
  void next_command() {
    if (next_ < action_.commands.size()) {
      v1::ClientMessage m;
      *m.mutable_command() = action_.commands[next_];
      send(m);
      return;
    }
    // all answered: wait for what they changed (a SceneInfo after tool or parameters, a Stats for
    // pause and recording), then print it
    waiting_for_after_ = true;
    after_scene_ = after_stats_ = false;
  }

  void handle(const v1::ServerMessage& m) {
    switch (m.msg_case()) {
      case v1::ServerMessage::kWelcome:
        welcomed_ = true;
        if (m.welcome().role() != (action_.observer ? v1::OBSERVER : v1::CONTROLLER))
          return fail("palpd admitted this client as an observer, not the controller");
        next_command();
        break;
      case v1::ServerMessage::kScene:
        if (!scene_before_) scene_before_ = m.scene();
        scene_now_ = m.scene();
        if (waiting_for_after_) after_scene_ = true;
        break;
      case v1::ServerMessage::kStats:
        stats_ = m.stats();
        if (waiting_for_after_) after_stats_ = true;
        break;
      case v1::ServerMessage::kTask:
        task_ = m.task();
        if (waiting_for_after_) after_task_ = true;
        break;
      case v1::ServerMessage::kResult: {
        const v1::CommandResult& r = m.result();
        if (next_ >= action_.commands.size() ||
            r.request_id() != action_.commands[next_].request_id())
          break;
        const std::string& what = action_.what[next_];
        if (r.ok()) {
          any_ok_ = true;
          std::printf("%s: ok%s%s\n", what.c_str(), r.message().empty() ? "" : ": ",
                      r.message().c_str());
        } else {
          std::printf("%s: refused: %s\n", what.c_str(), r.message().c_str());
          refused_ = true;
          waiting_for_after_ = true;
          after_scene_ = after_stats_ = true;
          return report();
        }
        ++next_;
        next_command();
        break;
      }
      case v1::ServerMessage::kError:
        if (m.error().fatal())
          return fail("palpd refused: " + v1::Error::Code_Name(m.error().code()) + ": " +
                      m.error().reason());
        std::fprintf(stderr, "palp ctl: palpd says: %s\n", m.error().reason().c_str());
        break;
      default:
        break;
    }
    if (!waiting_for_after_) return;
    // a task action: the TaskStatus after it (or, from a palpd without tasks, the Stats alone)
    if (action_.task ? after_task_ || (after_stats_ && !task_)
                     : after_stats_ && (after_scene_ || !changes_scene()))
      report();
  }

  bool changes_scene() const {
    for (const v1::Command& c : action_.commands)
      if (c.has_set_parameter() || c.has_set_tool()) return true;
    return false;
  }

  void report() {
    if (action_.task) {
      if (task_)
        std::printf("%s", task_status_text(*task_).c_str());
      else
        std::printf("task       this palpd runs no training tasks (start it with --landmarks)\n");
      return finish();
    }
    if (action_.status) print_status();
    if (changes_scene() && scene_before_ && any_ok_) print_changes();
    if (!action_.status && stats_)
      std::printf("now: %s, %s\n", stats_->paused() ? "paused" : "running",
                  stats_->recording() ? "recording" : "not recording");
    finish();
  }

  static std::vector<std::pair<std::string, std::string>> parameter_lines(const v1::SceneInfo& s) {
    std::vector<std::pair<std::string, std::string>> out;
    out.emplace_back("tool", s.tool().name());
    const v1::Parameters& p = s.parameters();
    const auto num = [](double v) { return number_text(v); };
    out.emplace_back("model", p.model().empty() ? "paper" : p.model());
    out.emplace_back("c", num(p.c()));
    out.emplace_back("k", num(p.k()));
    out.emplace_back("bone_enabled", p.bone_enabled() ? "1" : "0");
    out.emplace_back("bone_fmax", num(p.bone_fmax()));
    out.emplace_back("bone_flip", num(p.bone_flip()));
    out.emplace_back("bone_mode", p.bone_mode());
    out.emplace_back("bone_k", num(p.bone_k()));
    out.emplace_back("mu", num(p.mu()));
    out.emplace_back("skin_fmax", num(p.skin_fmax_n()));
    out.emplace_back("bone_fade_mm", num(p.bone_fade_mm()));
    out.emplace_back("bone_reach_mm", num(p.bone_reach_mm()));
    out.emplace_back("bone_along_normal", p.bone_along_normal() ? "1" : "0");
    out.emplace_back("pulse_bpm", num(p.pulse_bpm()));
    return out;
  }

  void print_changes() const {
    const auto before = parameter_lines(*scene_before_), after = parameter_lines(scene_now_);
    bool any = false;
    for (std::size_t i = 0; i < before.size() && i < after.size(); ++i) {
      if (before[i].second == after[i].second) continue;
      std::printf("changed: %s %s -> %s\n", before[i].first.c_str(), before[i].second.c_str(),
                  after[i].second.c_str());
      any = true;
    }
    if (!any) std::printf("changed: nothing (the values were already in force)\n");
  }

  void print_status() const {
    if (scene_before_) {
      std::printf("scene      %s\n", scene_now_.source().c_str());
      std::string params;
      for (const auto& [k, v] : parameter_lines(scene_now_)) {
        if (k == "tool") continue;
        params += (params.empty() ? "" : ", ") + k + " " + v;
      }
      std::printf("tool       %s\nparameters %s\n", scene_now_.tool().name().c_str(),
                  params.c_str());
      std::printf(
          "device     %s%s\n", scene_now_.device().c_str(),
          scene_now_.has_limits() ? (", limits " + scene_now_.limits().profile()).c_str() : "");
    }
    if (stats_) {
      std::printf("state      %s, %s\n", stats_->paused() ? "paused" : "running",
                  stats_->recording() ? "recording" : "not recording");
      std::printf("loop       %.1f Hz of %.1f, %llu ticks, %llu overruns, %llu faults\n",
                  stats_->rate_hz(), stats_->target_rate_hz(),
                  static_cast<unsigned long long>(stats_->ticks()),
                  static_cast<unsigned long long>(stats_->overruns()),
                  static_cast<unsigned long long>(stats_->faults()));
      std::printf("clients    %u\n", stats_->clients());
    }
  }

  std::string host_, port_;
  v1::Hello hello_;
  Action action_;
  std::chrono::steady_clock::duration timeout_;
  asio::io_context io_;
  tls::ClientContext* tls_ = nullptr;
  client::ServerLink link_;
  std::size_t next_ = 0;
  bool welcomed_ = false, refused_ = false, any_ok_ = false;
  bool waiting_for_after_ = false, after_scene_ = false, after_stats_ = false;
  bool after_task_ = false;
  std::optional<v1::TaskStatus> task_;
  std::optional<v1::SceneInfo> scene_before_;
  v1::SceneInfo scene_now_;
  std::optional<v1::Stats> stats_;
  std::string failure_;
};

}  // namespace

int cmd_ctl(const Arguments& argv) {
  const Args args(argv, {"help"},
                  {"token", "config", "name", "timeout", "tls-ca", "tls-pin", "tls-cert", "tls-key",
                   "side", "space", "interspace"});
  if (args.has("help")) {
    std::cout << kCtlUsage;
    return 0;
  }
  const std::vector<std::string>& pos = args.positional();
  if (pos.empty()) throw UsageError("ctl needs HOST:PORT and an ACTION");
  const std::string& target = pos[0];
  std::string host;
  std::uint16_t port = 0;
  if (const std::string why = client::host_port_problem(target, host, port); !why.empty())
    throw UsageError("ctl needs HOST:PORT, got '" + target + "': " + why);
  std::vector<std::string> words(pos.begin() + 1, pos.end());
  for (const char* option : {"side", "space", "interspace"})  // task start's (ctl_task.hpp)
    if (const auto value = args.get(option)) {
      if (words.size() < 2 || words[0] != "task" || words[1] != "start")
        throw UsageError(std::string("--") + option + " is for ctl task start");
      words.insert(words.end(), {std::string("--") + option, *value});
    }
  const Action action = parse_action(words);
  const double timeout = args.number("timeout", 5.0);
  if (!(timeout > 0.0 && timeout <= 3600.0)) throw UsageError("--timeout must be in (0, 3600] s");
  std::string token = args.get("token").value_or("");
  if (token.empty())
    if (const auto config = args.get("config")) token = config_value(*config, "token").value_or("");

  v1::Hello hello;
  hello.set_protocol_version(wire::kProtocolVersion);
  hello.set_role(action.observer ? v1::OBSERVER : v1::CONTROLLER);
  hello.set_token(token);
  hello.set_client_name(args.get("name").value_or("palp-ctl"));
  hello.set_frame_rate_hz(1.0);  // frames are not what ctl is for
  const std::unique_ptr<tls::ClientContext> tls = client_tls(args);
  Session session(host, std::to_string(port), hello, action, timeout, tls.get());
  return session.run();
}

}  // namespace palp::cli
