// palpd's allow-list of controller subjects (proto/tls/controllers.cpp): the file's form as
// docs/security.md gives it (one RFC 2253 subject per line, openssl's "subject=" optional,
// comments and blank lines skipped) and the lists it refuses. Who it admits is tested end to end
// in tests/server/net/tls_accept_test.cpp.
#include "tls/controllers.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "base/errors.hpp"

namespace palp::tls {
namespace {

TEST(ControllerSubjects, OneSubjectPerLineAsOpensslPrintsIt) {
  const auto subjects = parse_controller_subjects(
      "# controller stations\n"
      "subject=CN=station-3,O=palp lab\n"
      "\n"
      "  CN=station-4,O=palp lab  \r\n"
      "subject= CN=Müller\\, Anna,O=palp lab\n",
      "controllers");
  ASSERT_EQ(subjects.size(), 3u);
  EXPECT_EQ(subjects[0], "CN=station-3,O=palp lab");
  EXPECT_EQ(subjects[1], "CN=station-4,O=palp lab");
  EXPECT_EQ(subjects[2], "CN=Müller\\, Anna,O=palp lab");
}

TEST(ControllerSubjects, RefusesAnEmptyListAndBadLines) {
  EXPECT_THROW(parse_controller_subjects("", "f"), InputError);
  EXPECT_THROW(parse_controller_subjects("# only a comment\n\n", "f"), InputError);
  try {
    parse_controller_subjects("CN=a\nsubject=\n", "controllers.txt");
    ADD_FAILURE() << "an empty subject was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("controllers.txt:2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parse_controller_subjects("CN=a\x01,O=b\n", "f"), InputError);
  EXPECT_THROW(parse_controller_subjects("CN=" + std::string(2000, 'a') + "\n", "f"), InputError);
}

TEST(ControllerSubjects, ReadsAFileAndNamesOneItCannotRead) {
  const auto file =
      std::filesystem::temp_directory_path() / ("palp_controllers_" + std::to_string(::getpid()));
  std::ofstream(file) << "subject=CN=station-3,O=palp lab\n";
  const auto subjects = read_controller_subjects(file.string());
  ASSERT_EQ(subjects.size(), 1u);
  EXPECT_EQ(subjects[0], "CN=station-3,O=palp lab");
  std::filesystem::remove(file);
  EXPECT_THROW(read_controller_subjects(file.string()), ResourceError);
}

}  // namespace
}  // namespace palp::tls
