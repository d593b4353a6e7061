#include <gtest/gtest.h>

#include "hpddo/crc.h"

static const uint8_t kCheck[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};

TEST(Crc, Crc16CcittFalseCheckValue) { EXPECT_EQ(hpddo::crc16(kCheck, sizeof kCheck), 0x29B1u); }

TEST(Crc, Crc32IeeeCheckValue) { EXPECT_EQ(hpddo::crc32(kCheck, sizeof kCheck), 0xCBF43926u); }

TEST(Crc, Crc32InPiecesEqualsWhole) {
  uint32_t c = 0xFFFFFFFFu;
  c = hpddo::crc32_update(c, kCheck, 4);
  c = hpddo::crc32_update(c, kCheck + 4, 5);
  EXPECT_EQ(c ^ 0xFFFFFFFFu, 0xCBF43926u);
}

TEST(Crc, EmptyBuffer) {
  EXPECT_EQ(hpddo::crc16(kCheck, 0), 0xFFFFu);
  EXPECT_EQ(hpddo::crc32(kCheck, 0), 0u);
}

TEST(Crc, SingleBitFlipChangesBoth) {
  uint8_t buf[9];
  for (int k = 0; k < 9; ++k) buf[k] = kCheck[k];
  for (int bit = 0; bit < 72; ++bit) {
    buf[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    EXPECT_NE(hpddo::crc16(buf, 9), 0x29B1u);
    EXPECT_NE(hpddo::crc32(buf, 9), 0xCBF43926u);
    buf[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
  }
}
