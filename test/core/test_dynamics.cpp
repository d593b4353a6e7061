// The dynamic family's observer (hpddo/dynamics.h): the same bits as its Python reference
// (tools/hpddo/model/dynamics_ref.py) on the golden vector, the measured speed itself when the
// family is not named, and the physics of the mechanical balance.
#include <gtest/gtest.h>

#include "dynamics_golden.h"
#include "hpddo/dynamics.h"

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
    const float* r = dynamics_golden::kRows[k];
    const float n = obs.step(dynamics_golden::kKe, d, r[0], r[1], dynamics_golden::kDt);
    ASSERT_EQ(n, r[2]) << "sample " << k;
    ASSERT_EQ(obs.load_nm(), r[3]) << "sample " << k;
  }
}

TEST(Dynamics, NotNamedReturnsTheMeasuredSpeedItself) {
  hpddo::DynamicsParams d = golden_params();
  d.j_kgm2 = 0.0f;
  hpddo::DynamicsObserver obs;
  for (int k = 0; k < dynamics_golden::kN; ++k) {
    const float* r = dynamics_golden::kRows[k];
    const float n = obs.step(dynamics_golden::kKe, d, r[0], r[1], dynamics_golden::kDt);
    ASSERT_EQ(n, r[1]) << "sample " << k;
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
