// Unity test: the deployed model and its golden vectors (written by the
// exporter, the same file every host test reads), on the ESP8266
// (pio test -e esp8266) and on the desk (pio test -e native).
#include <math.h>
#include <unity.h>

#include "golden_default.h"
#include "infer_link.h"
#include "model_default.h"

namespace gold = hpddo_golden_default;
namespace mdl = hpddo_model_default;

void setUp() {}
void tearDown() {}

static float g(int r, int c) { return gold::at(static_cast<uint16_t>(r), static_cast<uint8_t>(c)); }

static void test_checksum() {
  TEST_ASSERT_EQUAL_HEX32(mdl::kChecksum, hpddo::model_checksum(mdl::kModel));
}

static void test_golden_rows() {
  static hpddo::Observer<mdl::Net> obs(mdl::kModel);
  for (uint16_t r = 0; r < gold::kCount; ++r) {
    const hpddo::Sample s = gold::sample(r);
    const hpddo::Estimate e = obs.step(s);
    const float want = g(r, gold::kCol_rpm);
    const float mag = want < 0.0f ? -want : want;
    const float tol = 1e-4f * (mag > 1.0f ? mag : 1.0f);
    TEST_ASSERT_FLOAT_WITHIN(tol, want, e.rpm);
    TEST_ASSERT_EQUAL_INT(static_cast<int>(g(r, gold::kCol_status)), static_cast<int>(e.status));
    TEST_ASSERT_FLOAT_WITHIN(1e-4f, g(r, gold::kCol_confidence), e.confidence);  // the novelty gate's weight
  }
}

static int run() {
  UNITY_BEGIN();
  RUN_TEST(test_checksum);
  RUN_TEST(test_golden_rows);
  return UNITY_END();
}

#include "../unity_main.h"
