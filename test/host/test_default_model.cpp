// The committed default model (models/default) against its golden vectors,
// computed by numpy in float32 when the model was exported.
#include <cmath>

#include <gtest/gtest.h>

#include "golden.h"
#include "golden_default.h"
#include "model_default.h"

TEST(DefaultModel, ChecksumMatchesTheBanner) {
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_default::kModel), hpddo_model_default::kChecksum);
}

TEST(DefaultModel, EveryStageMatchesGoldenWithin1e4Relative) {
  using namespace hpddo_golden_default;
  using Net = hpddo_model_default::Net;
  hpddo::Observer<Net> obs(hpddo_model_default::kModel);
  int statuses[5] = {0, 0, 0, 0, 0};  // one per hpddo::Status
  for (int r = 0; r < kCount; ++r) {
    const auto g = [&](int c) { return at(static_cast<uint16_t>(r), static_cast<uint8_t>(c)); };
    const hpddo::Sample s = sample(static_cast<uint16_t>(r));
    // The stages below the observer, from the golden inputs of each stage.
    if (!std::isnan(g(kCol_z0))) {
      float x[5], z[5];
      for (int j = 0; j < 5; ++j) x[j] = g(kCol_x0 + j);
      hpddo_model_default::kModel.scaler.transform(x, z);
      for (int j = 0; j < 5; ++j) EXPECT_TRUE(golden::close(z[j], g(kCol_z0 + j))) << "row " << r << " z" << j;
      float zg[5];
      for (int j = 0; j < 5; ++j) zg[j] = g(kCol_z0 + j);
      EXPECT_TRUE(golden::close(Net::forward(hpddo_model_default::kModel.weights, zg), g(kCol_mlp_rpm))) << "row " << r;
    }
    const hpddo::Estimate e = obs.step(s);
    ASSERT_EQ(static_cast<int>(e.status), static_cast<int>(g(kCol_status))) << "row " << r;
    ++statuses[e.status];
    EXPECT_TRUE(golden::close(e.rpm_m2, g(kCol_rpm_m2))) << "row " << r;
    EXPECT_TRUE(golden::close(e.residual_rpm, g(kCol_residual_rpm))) << "row " << r;
    EXPECT_TRUE(golden::close(e.rpm, g(kCol_rpm))) << "row " << r;
    EXPECT_TRUE(golden::close(e.temp_C, g(kCol_temp_used_C))) << "row " << r;
    EXPECT_TRUE(golden::close(e.confidence, g(kCol_confidence))) << "row " << r;
  }
  EXPECT_GT(statuses[hpddo::kStatusOk] + statuses[hpddo::kStatusClamped], kCount / 2);
  EXPECT_GT(statuses[hpddo::kStatusInvalid], 0);
}
