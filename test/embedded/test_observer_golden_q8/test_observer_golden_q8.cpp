// Unity test: the int8 model (model_default_q8.h, issue 24) and its golden vectors from
// the integer reference (tools/hpddo/model/quant.py), on the boards: on the ATmega328P in
// simavr this runs mlp_q.h's assembly rows (dot_lpm8), which the host tests do not.
#include <unity.h>

#include "../golden_rows.h"

#include "golden_default_q8.h"
#include "model_default_q8.h"

namespace gold = hpddo_golden_default_q8;
namespace mdl = hpddo_model_default_q8;

void setUp() {}
void tearDown() {}

static float g(int r, int c) { return gold::at(static_cast<uint16_t>(r), static_cast<uint8_t>(c)); }

static void test_checksum() {
  TEST_ASSERT_EQUAL_HEX32(mdl::kChecksum, hpddo::model_checksum(mdl::kModel));
}

/// The quantised inputs and the output accumulator of every row, bit for bit.
static void test_network_bit_for_bit() {
  for (uint16_t r = 0; r < gold::kCount; ++r) {
    float x[5];
    for (uint8_t j = 0; j < 5; ++j) x[j] = g(r, gold::kCol_x0 + j);
    int16_t xq[5];
    mdl::Net::quantise(mdl::kModel.weights, x, xq);
    for (uint8_t j = 0; j < 5; ++j) TEST_ASSERT_EQUAL_INT32(gold::int_at(r, gold::kInt_xq0 + j), xq[j]);
    TEST_ASSERT_EQUAL_INT32(gold::int_at(r, gold::kInt_acc), mdl::Net::forward_acc(mdl::kModel.weights, xq));
  }
}

static void test_golden_rows() {
  static hpddo::Observer<mdl::Net> obs(mdl::kModel);
  const GoldenColumns col = {gold::kCount, gold::kCol_rpm, gold::kCol_status, gold::kCol_confidence};
  check_golden_rows(&obs, col, gold::at, gold::sample);
}

static int run() {
  UNITY_BEGIN();
  RUN_TEST(test_checksum);
  RUN_TEST(test_network_bit_for_bit);
  RUN_TEST(test_golden_rows);
  return UNITY_END();
}

#include "../unity_main.h"
