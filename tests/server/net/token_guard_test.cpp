// Wrong-token back-off: exact waits, the right token resets, the table stays bounded, logging is
// rate-limited.
#include "net/token_guard.hpp"

#include <gtest/gtest.h>

#include <string>

namespace palp::net {
namespace {

constexpr std::int64_t kMs = 1'000'000;

TEST(TokenGuard, ThreeFreeThenDoublingWaits) {
  TokenGuard g;
  EXPECT_EQ(g.wait_ns("a", 0), 0);
  g.failed("a", 0);
  g.failed("a", 0);
  EXPECT_EQ(g.wait_ns("a", 0), 0);  // two mistakes cost nothing
  g.failed("a", 0);
  EXPECT_EQ(g.wait_ns("a", 0), 100 * kMs);
  g.failed("a", 200 * kMs);
  EXPECT_EQ(g.wait_ns("a", 200 * kMs), 200 * kMs);
  for (int i = 0; i < 30; ++i) g.failed("a", 0);
  EXPECT_EQ(g.wait_ns("a", 0), 30'000 * kMs);  // at most 30 s
  EXPECT_EQ(g.wait_ns("b", 0), 0);             // per address
  g.succeeded("a");
  EXPECT_EQ(g.wait_ns("a", 0), 0);
}

TEST(TokenGuard, BoundedTableAndRateLimitedLogging) {
  TokenGuard g;
  int logged = 0;
  for (std::size_t i = 0; i < TokenGuard::kMaxAddresses + 50; ++i)
    logged += g.failed("10.0.0." + std::to_string(i), static_cast<std::int64_t>(i) * kMs);
  EXPECT_EQ(g.addresses(), TokenGuard::kMaxAddresses);
  EXPECT_EQ(g.total(), TokenGuard::kMaxAddresses + 50);
  EXPECT_EQ(logged, 2);  // at 0 ms and at 1000 ms
}

TEST(SameToken, EqualOnlyWhenLengthAndEveryByteAgree) {
  EXPECT_TRUE(same_token("s3cret", "s3cret"));
  EXPECT_TRUE(same_token("", ""));
  EXPECT_FALSE(same_token("s3cre", "s3cret"));
  EXPECT_FALSE(same_token("s3cret!", "s3cret"));
  EXPECT_FALSE(same_token("s3creT", "s3cret"));
  EXPECT_FALSE(same_token("", "s3cret"));
  EXPECT_FALSE(same_token(std::string("s3\0ret", 6), "s3cret"));
}

}  // namespace
}  // namespace palp::net
