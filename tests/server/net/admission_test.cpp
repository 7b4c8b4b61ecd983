// The Hello checks, one refusal each, and the order they come in: version, clear-text token,
// observers' limit, token back-off, wrong token, second controller.
#include "net/admission.hpp"

#include <gtest/gtest.h>

#include "net/protocol.hpp"

namespace palp::net {
namespace {

v1::Hello hello(v1::Role role, const std::string& token = "") {
  v1::Hello h;
  h.set_protocol_version(kProtocolVersion);
  h.set_role(role);
  h.set_token(token);
  return h;
}

ServerConfig config_with_token() {
  ServerConfig c;
  c.max_clients = 2;
  c.token = "secret";
  return c;
}

TEST(Admission, ObserversJoinUpToMaxClientsWithTheControllerSlotKept) {
  const ServerConfig c = config_with_token();
  TokenGuard guard;
  HelloFacts facts{nullptr, false, "127.0.0.1"};
  facts.observers = 1;
  facts.controller_taken = true;
  EXPECT_FALSE(check_hello(hello(v1::OBSERVER), facts, c, guard, 0));
  facts.observers = 2;
  const auto full = check_hello(hello(v1::OBSERVER), facts, c, guard, 0);
  ASSERT_TRUE(full);
  EXPECT_EQ(full->code, v1::Error::TOO_MANY_CLIENTS);
  EXPECT_EQ(full->reason, "the server is full (2 clients)");
  facts.controller_taken = false;  // the controller's slot does not count against max_clients
  EXPECT_FALSE(check_hello(hello(v1::CONTROLLER, "secret"), facts, c, guard, 0));
}

TEST(Admission, OtherVersionsAreRefusedFirst) {
  v1::Hello h = hello(v1::CONTROLLER, "wrong");
  h.set_protocol_version(kProtocolVersion + 1);
  TokenGuard guard;
  const auto no =
      check_hello(h, HelloFacts{nullptr, false, "10.0.0.2"}, config_with_token(), guard, 0);
  ASSERT_TRUE(no);
  EXPECT_EQ(no->code, v1::Error::VERSION_MISMATCH);
  EXPECT_EQ(guard.total(), 0u);  // no token was judged
}

TEST(Admission, ATokenInClearTextOffLoopbackIsRefusedBeforeItIsCompared) {
  TokenGuard guard;
  const ServerConfig c = config_with_token();
  const auto no = check_hello(hello(v1::CONTROLLER, "secret"),
                              HelloFacts{nullptr, false, "10.0.0.2"}, c, guard, 0);
  ASSERT_TRUE(no);
  EXPECT_EQ(no->code, v1::Error::UNAUTHORIZED);
  EXPECT_FALSE(no->token_refused);
  EXPECT_EQ(guard.total(), 0u);
  EXPECT_FALSE(check_hello(hello(v1::CONTROLLER, "secret"), HelloFacts{nullptr, true, "10.0.0.2"},
                           c, guard, 0));  // over TLS it may
}

TEST(Admission, WrongTokensAreCountedThenMadeToWait) {
  TokenGuard guard;
  const ServerConfig c = config_with_token();
  const HelloFacts facts{nullptr, false, "127.0.0.1"};
  const auto missing = check_hello(hello(v1::CONTROLLER), facts, c, guard, 0);
  ASSERT_TRUE(missing);
  EXPECT_TRUE(missing->token_refused);
  EXPECT_EQ(missing->reason, "CONTROLLER needs the server's token: none was given");
  for (int i = 0; i < 2; ++i) {
    const auto wrong = check_hello(hello(v1::CONTROLLER, "guess"), facts, c, guard, 0);
    ASSERT_TRUE(wrong);
    EXPECT_EQ(wrong->reason, "CONTROLLER needs the server's token: the one given is wrong");
  }
  EXPECT_EQ(guard.total(), 3u);
  // the fourth try, even with the right token, waits 100 ms
  const auto wait = check_hello(hello(v1::CONTROLLER, "secret"), facts, c, guard, 0);
  ASSERT_TRUE(wait);
  EXPECT_EQ(wait->reason, "too many wrong tokens from 127.0.0.1: wait 100 ms");
  EXPECT_FALSE(wait->token_refused);
  EXPECT_FALSE(check_hello(hello(v1::CONTROLLER, "secret"), facts, c, guard, 100'000'000));
  EXPECT_EQ(guard.wait_ns("127.0.0.1", 100'000'000), 0);  // the right token starts afresh
}

TEST(Admission, OneControllerAtATime) {
  TokenGuard guard;
  HelloFacts facts{nullptr, false, "127.0.0.1"};
  facts.controller_taken = true;
  const auto busy =
      check_hello(hello(v1::CONTROLLER, "secret"), facts, config_with_token(), guard, 0);
  ASSERT_TRUE(busy);
  EXPECT_EQ(busy->code, v1::Error::CONTROLLER_BUSY);
}

}  // namespace
}  // namespace palp::net
