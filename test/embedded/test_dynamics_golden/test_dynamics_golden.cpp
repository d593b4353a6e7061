// Unity test: the dynamic family (hpddo/dynamics.h, issue 21 item 8) on the boards, against its
// Python references, bit for bit:
//  - hpddo::exp_neg, the observer's pole, on its golden rows (dynamics_golden.h's kExp);
//  - DynamicsObserver on its golden vector (test/fixtures/dynamics_golden.h, from
//    tools/hpddo/model/dynamics_ref.py): speed and load torque of every sample;
//  - the UNO's observer (the fixed-point model, Observer<Net, dynamics_named(kDynamics)> as
//    uno_acq.cpp builds it) with a model that names the family (test/fixtures/dynamics: the
//    deployed model with a slow shaft, `tools/gen_fixtures.py`) on its golden vectors
//    (hpddo.model.observer_ref with quant.forward_int): the family's estimate n_M2, the final
//    estimate, the confidence and the status of every row.
// On the ATmega328P in simavr (avr-libc's float and expf), the host and the lx106 in QEMU.
#include <string.h>
#include <unity.h>

// The fixture's headers by their path (quoted includes look beside the including file first, so
// model_default_q.h takes the fixture's model_default.h, not models/default's).
#include "../../fixtures/dynamics/golden_default_q.h"
#include "../../fixtures/dynamics/model_default_q.h"
#include "../../fixtures/dynamics_golden.h"

namespace gold = hpddo_golden_default_q;
namespace mdl = hpddo_model_default_q;

void setUp() {}
void tearDown() {}

static uint32_t bits(float x) {
  uint32_t u;
  memcpy(&u, &x, sizeof u);
  return u;
}

static float g(int r, int c) { return gold::at(static_cast<uint16_t>(r), static_cast<uint8_t>(c)); }

static void test_the_family_is_compiled_because_the_model_names_it() {
  static_assert(hpddo::dynamics_named(mdl::kDynamics), "the fixture names the dynamic family");
  // both checksums cover the family (its four floats last)
  TEST_ASSERT_EQUAL_HEX32(mdl::kChecksum, hpddo::model_checksum(mdl::kModel, mdl::kDynamics));
  TEST_ASSERT_EQUAL_HEX32(hpddo_model_default::kChecksum,
                          hpddo::model_checksum(hpddo_model_default::kModel, hpddo_model_default::kDynamics));
}

/// hpddo::DynamicsObserver: the golden vector's speed and load torque, to the bit.
static void test_dynamics_observer_bit_for_bit() {
  const hpddo::DynamicsParams d = {dynamics_golden::kJ, dynamics_golden::kB, dynamics_golden::kTc,
                                   dynamics_golden::kTau};
  static hpddo::DynamicsObserver obs;
  for (int k = 0; k < dynamics_golden::kN; ++k) {
    const float n = obs.step(dynamics_golden::kKe, d, dynamics_golden::at(k, 0), dynamics_golden::at(k, 1),
                             dynamics_golden::kDt);
    TEST_ASSERT_EQUAL_HEX32(bits(dynamics_golden::at(k, 2)), bits(n));
    TEST_ASSERT_EQUAL_HEX32(bits(dynamics_golden::at(k, 3)), bits(obs.load_nm()));
  }
}

/// hpddo::exp_neg, the observer's pole e^(-dt/tau): the reference's bits (not libm's expf, which
/// differs between the boards' C libraries).
static void test_exp_neg_bit_for_bit() {
  for (int k = 0; k < dynamics_golden::kExpN; ++k) {
    TEST_ASSERT_EQUAL_HEX32(bits(dynamics_golden::exp_at(k, 1)), bits(hpddo::exp_neg(dynamics_golden::exp_at(k, 0))));
  }
}

/// The UNO's observer with the family: every golden row's stages to the bit.
static void test_uno_observer_with_the_family_bit_for_bit() {
  static hpddo::Observer<mdl::Net, hpddo::dynamics_named(mdl::kDynamics)> obs(mdl::kModel, mdl::kDynamics);
  for (uint16_t r = 0; r < gold::kCount; ++r) {
    const hpddo::Estimate e = obs.step(gold::sample(r));
    TEST_ASSERT_EQUAL_INT(static_cast<int>(g(r, gold::kCol_status)), static_cast<int>(e.status));
    if (e.status == hpddo::kStatusInvalid) continue;  // the estimate held: NaN in the table
    TEST_ASSERT_EQUAL_HEX32(bits(g(r, gold::kCol_rpm_m2)), bits(e.rpm_m2));
    TEST_ASSERT_EQUAL_HEX32(bits(g(r, gold::kCol_rpm)), bits(e.rpm));
    TEST_ASSERT_EQUAL_HEX32(bits(g(r, gold::kCol_confidence)), bits(e.confidence));
  }
}

static int run() {
  UNITY_BEGIN();
  RUN_TEST(test_the_family_is_compiled_because_the_model_names_it);
  RUN_TEST(test_exp_neg_bit_for_bit);
  RUN_TEST(test_dynamics_observer_bit_for_bit);
  RUN_TEST(test_uno_observer_with_the_family_bit_for_bit);
  return UNITY_END();
}

#include "../unity_main.h"
