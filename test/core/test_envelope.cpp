#include <cmath>

#include <gtest/gtest.h>

#include "hpddo/envelope.h"

HPDDO_FLASH static const float kLo[2] = {0.0f, -1.0f};
HPDDO_FLASH static const float kHi[2] = {12.0f, 2.0f};
static const hpddo::Envelope<2> kEnv = {kLo, kHi};

TEST(Envelope, InsideAndOnTheEdges) {
  const float a[2] = {6.0f, 0.5f}, b[2] = {0.0f, -1.0f}, c[2] = {12.0f, 2.0f};
  EXPECT_TRUE(kEnv.contains(a));
  EXPECT_TRUE(kEnv.contains(b));
  EXPECT_TRUE(kEnv.contains(c));
}

TEST(Envelope, AnyFeatureOutsideFails) {
  const float a[2] = {12.001f, 0.5f}, b[2] = {6.0f, -1.5f};
  EXPECT_FALSE(kEnv.contains(a));
  EXPECT_FALSE(kEnv.contains(b));
}

TEST(Envelope, NanAndInfinityAreOutside) {
  const float a[2] = {NAN, 0.5f}, b[2] = {6.0f, INFINITY};
  EXPECT_FALSE(kEnv.contains(a));
  EXPECT_FALSE(kEnv.contains(b));
}
