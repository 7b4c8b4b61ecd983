// See controllers.hpp.
#include "tls/controllers.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "base/errors.hpp"

namespace palp::tls {

namespace {

constexpr std::size_t kMaxSubjectBytes = 1024;
constexpr std::size_t kMaxFileBytes = std::size_t{1} << 20;

std::string trimmed(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  const auto last = line.find_last_not_of(" \t\r");
  return line.substr(first, last - first + 1);
}

}  // namespace

std::vector<std::string> parse_controller_subjects(const std::string& text,
                                                   const std::string& file) {
  std::vector<std::string> subjects;
  std::istringstream in(text);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    std::string subject = trimmed(line);
    if (subject.empty() || subject[0] == '#') continue;
    if (subject.rfind("subject=", 0) == 0) subject = trimmed(subject.substr(8));
    const auto where = [&] { return file + ":" + std::to_string(number) + ": "; };
    if (subject.size() > kMaxSubjectBytes)
      throw InputError(where() + "a subject longer than 1024 bytes");
    for (const char c : subject)
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
        throw InputError(where() + "a control character in the subject");
    if (subject.empty()) throw InputError(where() + "'subject=' without a subject");
    subjects.push_back(subject);
  }
  if (subjects.empty())
    throw InputError(file +
                     " lists no controller subject (one per line, as `openssl x509 -noout "
                     "-subject -nameopt RFC2253 -in CERT` prints it)");
  return subjects;
}

std::vector<std::string> read_controller_subjects(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in)
    throw ResourceError("cannot read --tls-controllers " + file + ": " + std::strerror(errno));
  std::string text(kMaxFileBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(in.gcount()));
  if (text.size() > kMaxFileBytes)
    throw ResourceError("--tls-controllers " + file + " is larger than 1 MiB");
  return parse_controller_subjects(text, file);
}

}  // namespace palp::tls
