#include <gtest/gtest.h>

#include "golden.h"
#include "golden_tiny.h"
#include "golden_tiny1.h"
#include "model_tiny.h"

TEST(Scaler, StandardisesEachFeature) {
  HPDDO_FLASH static const float kMean[3] = {1.0f, -2.0f, 100.0f};
  HPDDO_FLASH static const float kScale[3] = {2.0f, 0.5f, 10.0f};
  const hpddo::Scaler<3> s = {kMean, kScale};
  const float x[3] = {5.0f, -2.0f, 85.0f};
  float z[3];
  s.transform(x, z);
  EXPECT_FLOAT_EQ(z[0], 2.0f);
  EXPECT_FLOAT_EQ(z[1], 0.0f);
  EXPECT_FLOAT_EQ(z[2], -1.5f);
}

TEST(Scaler, MatchesGoldenStage) {
  using namespace hpddo_golden_tiny;
  const hpddo::Scaler<5>& s = hpddo_model_tiny::kModel.scaler;
  int checked = 0;
  for (int r = 0; r < kCount; ++r) {
    if (std::isnan(at(static_cast<uint16_t>(r), static_cast<uint8_t>(kCol_z0)))) continue;
    float x[5], z[5];
    for (int j = 0; j < 5; ++j) x[j] = at(static_cast<uint16_t>(r), static_cast<uint8_t>(kCol_x0 + j));
    s.transform(x, z);
    for (int j = 0; j < 5; ++j) EXPECT_TRUE(golden::close(z[j], at(static_cast<uint16_t>(r), static_cast<uint8_t>(kCol_z0 + j)))) << r;
    ++checked;
  }
  EXPECT_GT(checked, 20);  // the rows where the network runs (inside the envelope, gate weight > 0)
}
