// The host flash fake itself (built with HPDDO_FLASH_FAKE only): data declared
// HPDDO_FLASH reads right through flash_float() and wrong through a direct
// dereference, and flash_float() of a pointer to RAM stops the program, as the
// AVR's pgm_read_* would read the wrong memory in both cases.
#include <cstring>

#include <gtest/gtest.h>

#include "golden.h"
#include "golden_tiny.h"
#include "hpddo_core.h"
#include "model_tiny.h"

#ifndef HPDDO_FLASH_FAKE_ACTIVE
#error "test_flash_fake.cpp is built with -DHPDDO_FLASH_FAKE on a host"
#endif

namespace {

HPDDO_FLASH const float kValues[4] = {1.0f, -2.25f, 3.0e-7f, 180.0f};

/// A direct load the compiler cannot replace by the initialiser's value.
float direct(const float* p) {
  __asm__("" : "+r"(p));
  float f;
  std::memcpy(&f, p, sizeof f);
  return f;
}

}  // namespace

TEST(FlashFake, AccessorReadsTheStoredValues) {
  EXPECT_EQ(hpddo::flash_float(kValues + 0), 1.0f);
  EXPECT_EQ(hpddo::flash_float(kValues + 1), -2.25f);
  EXPECT_EQ(hpddo::flash_float(kValues + 2), 3.0e-7f);
  EXPECT_EQ(hpddo::flash_float(kValues + 3), 180.0f);
}

TEST(FlashFake, DirectDereferenceReadsWrongValues) {
  for (int k = 0; k < 4; ++k) EXPECT_NE(direct(kValues + k), hpddo::flash_float(kValues + k)) << k;
  // The generated model headers' arrays are masked too, without any change to them.
  using namespace hpddo_model_tiny;
  for (uint16_t k = 0; k < Net::kW0Count; ++k) EXPECT_NE(direct(kW0 + k), hpddo::flash_float(kW0 + k)) << k;
  EXPECT_NE(direct(kModel.scaler.mean), hpddo::flash_float(kModel.scaler.mean));
  EXPECT_NE(direct(kModel.envelope.hi), hpddo::flash_float(kModel.envelope.hi));
  EXPECT_NE(direct(hpddo_golden_tiny::kRows), hpddo_golden_tiny::at(0, 0));
}

TEST(FlashFake, ModelChecksumStillMatchesThroughTheAccessor) {
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_tiny::kModel), hpddo_model_tiny::kChecksum);
}

TEST(FlashFakeDeathTest, AccessorOnRamAborts) {
  static float ram[1] = {1.0f};
  EXPECT_DEATH(hpddo::flash_float(ram), "outside HPDDO_FLASH data");
}
