// The dynamic family's observer (hpddo/dynamics.h): the same bits as its Python reference
// (tools/hpddo/model/dynamics_ref.py) on the golden vector, the measured speed itself when the
// family is not named, and the physics of the mechanical balance; in the board's observer
// (Observer(kModel, kDynamics)) and the model checksum.
#include <math.h>
#include <string.h>

#include <gtest/gtest.h>

#include "dynamics_golden.h"
#include "golden_tiny.h"
#include "hpddo/dynamics.h"
#include "hpddo/observer.h"
#include "model_tiny.h"

namespace {
hpddo::DynamicsParams golden_params() {
  hpddo::DynamicsParams d = {dynamics_golden::kJ, dynamics_golden::kB, dynamics_golden::kTc, dynamics_golden::kTau};
  return d;
}
}  // namespace

TEST(Dynamics, SameBitsAsThePythonReference) {
  const hpddo::DynamicsParams d = golden_params();
  hpddo::DynamicsObserver obs;
  for (int k = 0; k < dynamics_golden::kN; ++k) {
    const float r[4] = {dynamics_golden::at(k, 0), dynamics_golden::at(k, 1), dynamics_golden::at(k, 2),
                        dynamics_golden::at(k, 3)};
    const float n = obs.step(dynamics_golden::kKe, d, r[0], r[1], dynamics_golden::kDt);
    ASSERT_EQ(n, r[2]) << "sample " << k;
    ASSERT_EQ(obs.load_nm(), r[3]) << "sample " << k;
  }
}

TEST(Dynamics, ExpNegSameBitsAsThePythonReferenceAndCloseToExpf) {
  for (int k = 0; k < dynamics_golden::kExpN; ++k) {
    const float x = dynamics_golden::exp_at(k, 0);
    const float e = hpddo::exp_neg(x);
    ASSERT_EQ(e, dynamics_golden::exp_at(k, 1)) << "x = " << x;
    if (x > -40.0f) {
      ASSERT_NEAR(e, expf(x), 2.5e-7f * expf(x)) << "x = " << x;  // within 1 ulp (2^-23 relative) and a half
    } else {
      ASSERT_EQ(e, 0.0f) << "x = " << x;
    }
  }
  EXPECT_EQ(hpddo::exp_neg(0.0f), 1.0f);
  EXPECT_EQ(hpddo::exp_neg(-40.0f), 0.0f);  // below: 0, p^2 never subnormal
}

TEST(Dynamics, NotNamedReturnsTheMeasuredSpeedItself) {
  hpddo::DynamicsParams d = golden_params();
  d.j_kgm2 = 0.0f;
  hpddo::DynamicsObserver obs;
  for (int k = 0; k < dynamics_golden::kN; ++k) {
    const float n = obs.step(dynamics_golden::kKe, d, dynamics_golden::at(k, 0), dynamics_golden::at(k, 1),
                             dynamics_golden::kDt);
    ASSERT_EQ(n, dynamics_golden::at(k, 1)) << "sample " << k;
  }
  EXPECT_EQ(obs.load_nm(), 0.0f);
}

TEST(Dynamics, SettledShaftStaysAndItsLoadTorqueIsTheBalance) {
  // At a constant current and speed the balance holds: Kt i = B w + Tc + T_L, so the observer
  // keeps the speed and reports T_L = Kt i - B w - Tc.
  const hpddo::DynamicsParams d = golden_params();
  const float ke = 0.355f, i = 0.6f, n = 150.0f;
  hpddo::DynamicsObserver obs;
  float out = 0.0f;
  for (int k = 0; k < 500; ++k) out = obs.step(ke, d, i, n, 0.01f);
  EXPECT_NEAR(out, n, 1e-3f);
  const float w = n / hpddo::kRpmPerRadS;
  EXPECT_NEAR(obs.load_nm(), ke * i - d.b_nms_per_rad * w - d.tc_nm, 1e-5f);
}

TEST(Dynamics, AStepOfTorqueAcceleratesTheShaftAtTorqueOverJ) {
  // The measurement held at the old speed, a step of current: the model's first prediction
  // moves the speed by dt Kt di / J, and the gain lw takes back its share.
  hpddo::DynamicsParams d = golden_params();
  const float ke = 0.355f, dt = 0.01f;
  hpddo::DynamicsObserver obs;
  obs.step(ke, d, 0.3f, 100.0f, dt);
  for (int k = 0; k < 300; ++k) obs.step(ke, d, 0.3f, 100.0f, dt);
  const float n1 = obs.step(ke, d, 0.5f, 100.0f, dt);
  const float g = dt / d.j_kgm2;
  const float a = 1.0f - g * d.b_nms_per_rad;
  const float p = expf(-dt / d.tau_obs_s);
  const float lw = 1.0f - p * p / a;
  const float dw_model = g * ke * 0.2f;  // rad/s
  EXPECT_NEAR(n1 - 100.0f, (1.0f - lw) * dw_model * hpddo::kRpmPerRadS, 0.05f);
}

TEST(Dynamics, UnusableSampleLeavesTheState) {
  const hpddo::DynamicsParams d = golden_params();
  hpddo::DynamicsObserver obs;
  obs.step(0.355f, d, 0.3f, 100.0f, 0.01f);
  const float load = obs.load_nm();
  EXPECT_EQ(obs.step(0.355f, d, 0.3f, 120.0f, 0.0f), 120.0f);
  EXPECT_EQ(obs.load_nm(), load);
}

// ---------------------------------------------------------------------------------------
// The family in the observer (observer.h: Observer(kModel, kDynamics)) and in the checksum.

namespace {
/// A shaft slow against the tiny stream's 0.5 s period, so that the observer filters.
hpddo::DynamicsParams slow_shaft() {
  hpddo::DynamicsParams d = {5e-3f, 4e-3f, 0.095f, 1.0f};
  return d;
}
}  // namespace

TEST(DynamicsInTheObserver, OffIsTheObserverAsBeforeBitForBit) {
  using Net = hpddo_model_tiny::Net;
  hpddo::Observer<Net> plain(hpddo_model_tiny::kModel);
  hpddo::Observer<Net> off(hpddo_model_tiny::kModel, hpddo::kDynamicsOff);
  for (uint16_t r = 0; r < hpddo_golden_tiny::kCount; ++r) {
    const hpddo::Sample s = hpddo_golden_tiny::sample(r);
    const hpddo::Estimate a = plain.step(s), b = off.step(s);
    // field by field, to the bit (a memcmp would read the struct's padding, which is not set)
    const float fa[] = {a.rpm, a.rpm_m2, a.residual_rpm, a.temp_C, a.confidence};
    const float fb[] = {b.rpm, b.rpm_m2, b.residual_rpm, b.temp_C, b.confidence};
    ASSERT_EQ(0, memcmp(fa, fb, sizeof fa)) << "row " << r;
    ASSERT_EQ(a.status, b.status) << "row " << r;
  }
}

TEST(DynamicsInTheObserver, NamedTheBackEmfSpeedIsItsMeasurementAndItsEstimateIsNM2) {
  // the tiny stream's ramp: 40 samples in one segment (seq without gaps, valid readings)
  using Net = hpddo_model_tiny::Net;
  const hpddo::DynamicsParams d = slow_shaft();
  hpddo::Observer<Net> off(hpddo_model_tiny::kModel);
  hpddo::Observer<Net> on(hpddo_model_tiny::kModel, d);
  hpddo::DynamicsObserver by_hand;
  const hpddo::PhysicsParams& p = hpddo_model_tiny::kModel.physics;
  float moved = 0.0f;
  for (uint16_t r = 0; r < 40; ++r) {
    const hpddo::Sample s = hpddo_golden_tiny::sample(r);
    const hpddo::Estimate a = off.step(s), b = on.step(s);
    ASSERT_NE(a.status, hpddo::kStatusInvalid) << "row " << r;
    const float want = by_hand.step(p.ke_vs_per_rad, d, hpddo::true_current_A(p, s.i_A), a.rpm_m2, s.dt_s);
    ASSERT_EQ(b.rpm_m2, want) << "row " << r;
    ASSERT_EQ(b.rpm, b.rpm_m2 + b.residual_rpm) << "row " << r;
    if (r == 0) {
      EXPECT_EQ(b.rpm_m2, a.rpm_m2);  // starts settled on the back-EMF speed
    }
    moved = fmaxf(moved, fabsf(b.rpm_m2 - a.rpm_m2));
  }
  EXPECT_GT(moved, 1.0f);  // and filters it where it changes
}

TEST(DynamicsInTheObserver, ChecksumCoversTheFamilyOnlyWhereNamed) {
  const uint32_t plain = hpddo::model_checksum(hpddo_model_tiny::kModel);
  EXPECT_EQ(hpddo::model_checksum(hpddo_model_tiny::kModel, hpddo::kDynamicsOff), plain);
  hpddo::DynamicsParams d = slow_shaft();
  const uint32_t named = hpddo::model_checksum(hpddo_model_tiny::kModel, d);
  EXPECT_NE(named, plain);
  d.tau_obs_s = 0.5f;
  EXPECT_NE(hpddo::model_checksum(hpddo_model_tiny::kModel, d), named);
}
