// The docs and the tools' --help agree (issue 24): every option a command's --help lists is
// mentioned in docs/ or README.md; every option a docs code block or inline code span gives a
// command is one its --help lists; and every command line in a docs code block parses (run with
// --help appended, exit 0: an unknown option or a malformed value exits 2; palp-lab
// (deploy/lab.sh) with --dry-run and the example lab file).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "support/cli_test_util.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::CliOutcome;
using testing::read_text;

// (not from __FILE__: a compiler cache may make that path relative)
const fs::path kSourceDir = PALP_SOURCE_DIR;
const fs::path kBuildDir = fs::path(PALP_CLI_PATH).parent_path().parent_path();

// The commands checked: "palp SUB" or a program, and the binary that runs it.
const std::map<std::string, fs::path>& commands() {
  static const std::map<std::string, fs::path> list = [] {
    std::map<std::string, fs::path> m;
    for (const char* sub :
         {"phantom", "prep", "run", "traj", "bench", "probe", "ctl", "tune", "task", "landmarks"})
      m[std::string("palp ") + sub] = PALP_CLI_PATH;
    m["palpd"] = kBuildDir / "server" / "palpd";
    m["palpview"] = kBuildDir / "client" / "palpview";
    m["palpchart"] = kBuildDir / "client" / "palpchart";
    m["palp-lab"] = kSourceDir / "deploy" / "lab.sh";  // installed as palp-lab
    return m;
  }();
  return list;
}

std::string quote(const std::string& word) {
  std::string out = "'";
  for (char c : word) {
    if (c == '\'') {
      out.append("'\\''");
    } else {
      out.push_back(c);
    }
  }
  out.push_back('\'');
  return out;
}

CliOutcome run_words(const fs::path& binary, const std::vector<std::string>& args) {
  std::string command = quote(binary.string());
  for (const auto& a : args) command.append(" ").append(quote(a));
  command.append(" 2>&1 </dev/null");
  CliOutcome outcome;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return outcome;
  char buffer[4096];
  while (fgets(buffer, sizeof buffer, pipe)) outcome.output += buffer;
  const int status = pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return outcome;
}

std::vector<std::string> command_prefix(const std::string& command) {
  if (command.rfind("palp ", 0) == 0) return {command.substr(5)};
  return {};
}

// The options of a --help text: those of its usage line, and of its option lines (indented a
// little, starting with a dash; the option column ends where two spaces start the description).
std::set<std::string> help_options(const std::string& help) {
  std::set<std::string> options;
  std::istringstream lines(help);
  const std::regex option_line("^ {1,6}-");
  const std::regex option("--[a-z][a-z0-9-]*");
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("usage:", 0) == 0) {
      for (std::sregex_iterator it(line.begin(), line.end(), option), end; it != end; ++it)
        options.insert(it->str());
      continue;
    }
    if (!std::regex_search(line, option_line)) continue;
    const auto first = line.find_first_not_of(' ');
    const auto gap = line.find("  ", first);
    const std::string column = line.substr(first, gap == std::string::npos ? gap : gap - first);
    for (std::sregex_iterator it(column.begin(), column.end(), option), end; it != end; ++it)
      options.insert(it->str());
  }
  return options;
}

const std::map<std::string, std::set<std::string>>& all_help_options() {
  static const std::map<std::string, std::set<std::string>> all = [] {
    std::map<std::string, std::set<std::string>> m;
    for (const auto& [command, binary] : commands()) {
      if (!fs::exists(binary)) continue;
      auto args = command_prefix(command);
      args.push_back("--help");
      m[command] = help_options(run_words(binary, args).output);
    }
    return m;
  }();
  return all;
}

std::vector<fs::path> doc_files() {
  std::vector<fs::path> files{kSourceDir / "README.md"};
  for (const auto& entry : fs::recursive_directory_iterator(kSourceDir / "docs"))
    if (entry.path().extension() == ".md") files.push_back(entry.path());
  return files;
}

struct DocCommand {
  std::string where;  // file:line
  std::string command;
  std::vector<std::string> args;  // after the command (and the palp subcommand)
  bool inline_span = false;       // a fragment in prose: its options are checked, it is not run
};

// A command line as a doc writes it -> the command and its arguments (none: not one of the
// commands): a leading `$ `, `xvfb-run -a`, `/usr/bin/time -v` and the binary's directory
// dropped, cut at a comment or a shell operator, [ ] ( ) and " dropped.
std::optional<DocCommand> parse_command(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string w; in >> w;) {
    if (w == "#" || w == "|" || w == "&&" || w == ";" || w == "&" || w[0] == '>' || w[0] == '<' ||
        w.rfind("2>", 0) == 0)
      break;
    std::string clean;
    for (char c : w)
      if (c != '[' && c != ']' && c != '(' && c != ')' && c != '"') clean += c;
    if (!clean.empty()) words.push_back(clean);
  }
  if (!words.empty() && words[0] == "$") words.erase(words.begin());
  if (words.size() >= 2 && words[0] == "xvfb-run" && words[1] == "-a")
    words.erase(words.begin(), words.begin() + 2);
  if (words.size() >= 2 && words[0] == "/usr/bin/time" && words[1] == "-v")
    words.erase(words.begin(), words.begin() + 2);
  if (words.empty()) return std::nullopt;
  if (words[0] == "deploy/lab.sh") words[0] = "palp-lab";
  std::string program = fs::path(words[0]).filename().string();
  if (words[0].find('/') != std::string::npos && words[0].rfind("build/", 0) != 0)
    return std::nullopt;
  std::string command = program;
  std::size_t args_from = 1;
  if (program == "palp") {
    if (words.size() < 2) return std::nullopt;
    command += " " + words[1];
    args_from = 2;
  }
  if (!commands().contains(command)) return std::nullopt;
  DocCommand doc{"", command, {}, false};
  doc.args.assign(words.begin() + static_cast<std::ptrdiff_t>(args_from), words.end());
  return doc;
}

// The command lines of the docs' fenced code blocks that run one of the commands (`\`
// continuations joined; blocks tagged other than sh, ```text for diagrams, are not commands),
// and the inline code spans that start with one (`palp prep --not-hu-ok`: inline).
std::vector<DocCommand> doc_commands() {
  std::vector<DocCommand> found;
  for (const auto& file : doc_files()) {
    std::istringstream lines(read_text(file));
    bool in_code = false, commands_block = false;
    int number = 0;
    for (std::string line; std::getline(lines, line);) {
      ++number;
      if (line.rfind("```", 0) == 0) {
        in_code = !in_code;
        const std::string tag = line.substr(3);
        commands_block = tag.empty() || tag == "sh" || tag == "bash" || tag == "console";
        continue;
      }
      if (!in_code) {
        const std::regex span("`([^`]+)`");
        for (std::sregex_iterator it(line.begin(), line.end(), span), end; it != end; ++it) {
          if (auto doc = parse_command((*it)[1].str())) {
            doc->where = file.filename().string() + ":" + std::to_string(number);
            doc->inline_span = true;
            found.push_back(*doc);
          }
        }
        continue;
      }
      if (!commands_block) continue;
      const int start = number;
      while (!line.empty() && line.back() == '\\') {
        std::string next;
        if (!std::getline(lines, next)) break;
        ++number;
        line.pop_back();
        line += " " + next;
      }
      if (auto doc = parse_command(line)) {
        doc->where = file.filename().string() + ":" + std::to_string(start);
        found.push_back(*doc);
      }
    }
  }
  return found;
}

TEST(DocsHelp, EveryHelpOptionIsDocumented) {
  std::string docs;
  for (const auto& file : doc_files()) docs += read_text(file);
  for (const auto& [command, options] : all_help_options()) {
    EXPECT_FALSE(options.empty()) << command << ": no options read from its --help";
    for (const auto& option : options) {
      const std::regex mention(option + "([^a-z0-9-]|$)");
      EXPECT_TRUE(std::regex_search(docs, mention))
          << command << " --help lists " << option << ", which docs/ and README.md never mention";
    }
  }
}

TEST(DocsHelp, EveryDocumentedOptionExists) {
  const auto docs = doc_commands();
  EXPECT_GT(docs.size(), 10u) << "the docs' code blocks show fewer commands than expected";
  for (const auto& doc : docs) {
    const auto options = all_help_options().find(doc.command);
    if (options == all_help_options().end()) continue;  // not built here
    for (const auto& arg : doc.args) {
      if (arg.rfind("--", 0) != 0) continue;
      const std::string option = arg.substr(0, arg.find('='));
      EXPECT_TRUE(options->second.contains(option))
          << doc.where << ": " << doc.command << " " << option << " is not in its --help";
    }
  }
}

TEST(DocsHelp, EveryDocumentedCommandLineParses) {
  for (const auto& doc : doc_commands()) {
    if (doc.inline_span) continue;
    const fs::path& binary = commands().at(doc.command);
    if (!fs::exists(binary)) continue;
    auto args = command_prefix(doc.command);
    const bool lab = doc.command == "palp-lab";
    for (const auto& arg : doc.args) {
      // A placeholder address stands for any; of alternatives a|b, the first; a lab file for
      // the example.
      if (arg == "HOST:PORT") {
        args.push_back("127.0.0.1:7400");
      } else if (lab && arg.ends_with(".toml")) {
        args.push_back((kSourceDir / "deploy" / "lab.example.toml").string());
      } else {
        args.push_back(arg.substr(0, arg.find('|')));
      }
    }
    // palp-lab runs for real without --help: --dry-run only prints its commands.
    if (!lab) args.push_back("--help");
    if (lab && std::find(args.begin(), args.end(), "--dry-run") == args.end())
      args.push_back("--dry-run");
    const CliOutcome run = run_words(binary, args);
    EXPECT_EQ(run.exit_code, 0) << doc.where << ": " << doc.command
                                << " does not parse: " << run.output.substr(0, 300);
  }
}

}  // namespace
}  // namespace palp
