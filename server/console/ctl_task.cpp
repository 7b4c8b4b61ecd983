// palp ctl's task actions: see ctl_task.hpp.
#include "console/ctl_task.hpp"

#include <cstdio>
#include <cstdlib>

#include "base/errors.hpp"

namespace palp::cli {

namespace {

v1::TaskStart parse_start(const std::vector<std::string>& words) {
  if (words.size() < 3) throw UsageError("ctl task start needs a KIND: ptcd, lumbar or femoral");
  v1::TaskStart start;
  start.set_kind(words[2]);
  for (std::size_t i = 3; i < words.size(); i += 2) {
    const std::string& option = words[i];
    if (i + 1 >= words.size()) throw UsageError("ctl task start: " + option + " needs a value");
    const std::string& value = words[i + 1];
    if (option == "--side") {
      start.set_side(value);
    } else if (option == "--space") {
      char* end = nullptr;
      const long space = std::strtol(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || space < 1 || space > 11)
        throw UsageError("ctl task start --space needs the upper rib, 1..11, got '" + value + "'");
      start.set_space(static_cast<std::uint32_t>(space));
    } else if (option == "--interspace") {
      start.set_interspace(value);
    } else {
      throw UsageError("ctl task start: unknown option '" + option +
                       "' (--side, --space, --interspace)");
    }
  }
  return start;
}

}  // namespace

CtlTaskAction parse_ctl_task(const std::vector<std::string>& words) {
  if (words.size() < 2) throw UsageError("ctl task needs start KIND, mark, next, stop or status");
  CtlTaskAction a;
  const std::string& verb = words[1];
  const auto no_more = [&] {
    if (words.size() > 2) throw UsageError("ctl task " + verb + ": unexpected '" + words[2] + "'");
  };
  v1::Command c;
  if (verb == "start") {
    *c.mutable_task_start() = parse_start(words);
    std::string what = "task start";
    for (std::size_t i = 2; i < words.size(); ++i) what += " " + words[i];
    a.what.push_back(what);
  } else if (verb == "mark") {
    no_more();
    c.mutable_task_mark();
    a.what.push_back("task mark");
  } else if (verb == "next") {
    no_more();
    c.mutable_task_next_trial();
    a.what.push_back("task next");
  } else if (verb == "stop") {
    no_more();
    c.mutable_task_stop();
    a.what.push_back("task stop");
  } else if (verb == "status") {
    no_more();
    a.observer = true;
    return a;
  } else {
    throw UsageError("unknown ctl task action '" + verb + "' (start, mark, next, stop, status)");
  }
  a.commands.push_back(c);
  return a;
}

std::string task_status_text(const v1::TaskStatus& s) {
  char line[512];
  std::string out;
  const auto add = [&](const char* label, const std::string& text) {
    std::snprintf(line, sizeof line, "%-10s %s\n", label, text.c_str());
    out += line;
  };
  if (s.task().empty()) {
    add("task", "none yet");
  } else {
    add("task", s.task() +
                    (s.running() ? ", running, trial " + std::to_string(s.trial())
                                 : std::string(", stopped")) +
                    ", " + std::to_string(s.marks()) + (s.marks() == 1 ? " mark" : " marks") +
                    ", " + std::to_string(s.trials_scored()) + " trials scored");
  }
  if (s.has_last_mark()) {
    const v1::TaskMarkScore& m = s.last_mark();
    std::snprintf(line, sizeof line, "%.1f mm from the target, %s (%s), at %.2f s", m.distance_mm(),
                  m.in_target() ? "in the target" : "not in the target", m.where().c_str(),
                  m.t_s());
    add("last mark", line);
  }
  add("landmarks", s.show_landmarks() ? "may be shown to this client"
                                      : "hidden from this client (the trainee, during a task)");
  if (s.samples_dropped() > 0 || s.marks_dropped() > 0)
    add("dropped", std::to_string(s.samples_dropped()) + " samples, " +
                       std::to_string(s.marks_dropped()) + " marks");
  if (!s.report().empty()) add("report", s.report());
  if (!s.note().empty()) add("note", s.note());
  return out;
}

}  // namespace palp::cli
