#include <cstring>

#include <gtest/gtest.h>

#include "model_tiny.h"
#include "model_tiny1.h"

TEST(Model, ChecksumOfTheStoredDataMatchesTheBanner) {
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_tiny::kModel), hpddo_model_tiny::kChecksum);
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_tiny1::kModel), hpddo_model_tiny1::kChecksum);
}

TEST(Model, ChecksumSeesAnyChangedValue) {
  using namespace hpddo_model_tiny;
  float w0[Net::kW0Count];
  std::memcpy(w0, kW0, sizeof w0);
  hpddo::Model<Net> m = kModel;
  m.weights.w0 = w0;
  EXPECT_EQ(hpddo::model_checksum(m), kChecksum);
  w0[7] = std::nextafter(w0[7], 1e9f);  // one ulp
  EXPECT_NE(hpddo::model_checksum(m), kChecksum);
  hpddo::Model<Net> m2 = kModel;
  m2.physics.brush_V += 0.001f;
  EXPECT_NE(hpddo::model_checksum(m2), kChecksum);
  hpddo::Model<Net> m3 = kModel;
  m3.clamp_rpm = 6.5f;
  EXPECT_NE(hpddo::model_checksum(m3), kChecksum);
}

TEST(Model, ChecksumSeesTheEffectBits) {
  using namespace hpddo_model_tiny;
  for (uint16_t bit = 1; bit < 0x80u; bit = static_cast<uint16_t>(bit << 1)) {
    hpddo::Model<Net> m = kModel;
    m.physics.effects = static_cast<uint16_t>(m.physics.effects ^ bit);
    EXPECT_NE(hpddo::model_checksum(m), kChecksum) << "effect bit " << bit;
  }
}
