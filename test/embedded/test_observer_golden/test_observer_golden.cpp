// Unity test: the deployed model and its golden vectors (written by the
// exporter, the same file every host test reads), on the ESP8266
// (pio test -e esp8266) and on the desk (pio test -e native).
#include <unity.h>

#include "../golden_rows.h"

#include "golden_default.h"
#include "infer_link.h"
#include "model_default.h"

namespace gold = hpddo_golden_default;
namespace mdl = hpddo_model_default;

void setUp() {}
void tearDown() {}

static void test_checksum() {
  TEST_ASSERT_EQUAL_HEX32(mdl::kChecksum, hpddo::model_checksum(mdl::kModel));
}

static void test_golden_rows() {
  static hpddo::Observer<mdl::Net> obs(mdl::kModel);
  const GoldenColumns col = {gold::kCount, gold::kCol_rpm, gold::kCol_status, gold::kCol_confidence};
  check_golden_rows(&obs, col, gold::at, gold::sample);
}

static int run() {
  UNITY_BEGIN();
  RUN_TEST(test_checksum);
  RUN_TEST(test_golden_rows);
  return UNITY_END();
}

#include "../unity_main.h"
