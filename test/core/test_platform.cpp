#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "hpddo/platform.h"

TEST(Platform, IsFiniteRejectsNanAndInfinities) {
  EXPECT_TRUE(hpddo::is_finite(0.0f));
  EXPECT_TRUE(hpddo::is_finite(-3.0e38f));
  EXPECT_TRUE(hpddo::is_finite(std::numeric_limits<float>::denorm_min()));
  EXPECT_FALSE(hpddo::is_finite(std::numeric_limits<float>::quiet_NaN()));
  EXPECT_FALSE(hpddo::is_finite(std::numeric_limits<float>::infinity()));
  EXPECT_FALSE(hpddo::is_finite(-std::numeric_limits<float>::infinity()));
}

TEST(Platform, AbsentIsNan) { EXPECT_TRUE(std::isnan(hpddo::absent())); }

TEST(Platform, FlashFloatReadsTheStoredValue) {
  HPDDO_FLASH static const float kValues[3] = {1.5f, -2.25f, 3.0e-7f};
  EXPECT_EQ(hpddo::flash_float(kValues + 0), 1.5f);
  EXPECT_EQ(hpddo::flash_float(kValues + 1), -2.25f);
  EXPECT_EQ(hpddo::flash_float(kValues + 2), 3.0e-7f);
}
