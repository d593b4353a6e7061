#include <cmath>

#include <gtest/gtest.h>

#include "hpddo/clamp.h"

TEST(Clamp, InsideBoundUntouched) {
  float r = 3.5f;
  EXPECT_FALSE(hpddo::clamp_residual(20.9f, &r));
  EXPECT_EQ(r, 3.5f);
  r = -20.9f;
  EXPECT_FALSE(hpddo::clamp_residual(20.9f, &r));
  EXPECT_EQ(r, -20.9f);
}

TEST(Clamp, OutsideBoundLimitedBothWays) {
  float r = 50.0f;
  EXPECT_TRUE(hpddo::clamp_residual(20.9f, &r));
  EXPECT_EQ(r, 20.9f);
  r = -1e30f;
  EXPECT_TRUE(hpddo::clamp_residual(20.9f, &r));
  EXPECT_EQ(r, -20.9f);
}

TEST(Clamp, BoundsTheTotalError) {
  // |n_M3 - n| <= |n_M2 - n| + bound for any raw residual (paper eq. 26)
  const float n_true = 200.0f, n_m2 = 195.0f, bound = 6.0f;
  for (float raw = -1000.0f; raw <= 1000.0f; raw += 0.5f) {
    float r = raw;
    hpddo::clamp_residual(bound, &r);
    EXPECT_LE(std::fabs(n_m2 + r - n_true), std::fabs(n_m2 - n_true) + bound + 1e-4f);
  }
}
