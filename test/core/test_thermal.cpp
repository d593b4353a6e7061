#include <cmath>

#include <gtest/gtest.h>

#include "hpddo/thermal.h"
#include "motor.h"

namespace {
hpddo::PhysicsParams params() {
  hpddo::PhysicsParams p = motor::plain(30.0f);
  p.ra_tc_per_K = 0.00393f;
  p.th_r_K_per_W = 8.0f;
  p.th_tau_s = 600.0f;
  p.t_amb_C = 30.0f;
  return p;
}
}  // namespace

TEST(Thermal, DisabledWithoutNetwork) {
  hpddo::PhysicsParams p = params();
  p.th_tau_s = 0.0f;
  hpddo::ThermalEstimator t;
  t.step(p, 2.0f, 10.0f, 30.0f);
  EXPECT_EQ(t.temp_C(30.0f), 30.0f);
}

TEST(Thermal, OneStepIsTheExactSolutionOfTheLinearNode) {
  hpddo::PhysicsParams p = params();
  p.ra_tc_per_K = 0.0f;  // constant loss: the node is linear, closed form exists
  hpddo::ThermalEstimator t;
  t.step(p, 1.0f, 300.0f, 30.0f);
  const double rise_ss = 8.0 * 1.0 * 4.5;
  EXPECT_NEAR(t.temp_C(30.0f), 30.0 + rise_ss * (1.0 - std::exp(-0.5)), 1e-4);
}

TEST(Thermal, CachedDecayEqualsTheDecayOfEachStep) {
  // The decay exp(-dt / tau) is kept between steps of the same period and time
  // constant: the trajectory must be the one of a fresh computation at every step,
  // through changes of the period and of the time constant.
  hpddo::PhysicsParams p = params();
  hpddo::ThermalEstimator cached;
  float rise = 0.0f;
  const float dts[] = {0.5f, 0.5f, 0.01f, 0.01f, 0.5f, 2.0f, 2.0f};
  for (int k = 0; k < 70; ++k) {
    const float dt = dts[k % 7];
    if (k == 35) p.th_tau_s = 300.0f;
    const float i = 0.5f + 0.02f * static_cast<float>(k % 9);
    cached.step(p, i, dt, 30.0f);
    // The node's step written out (thermal.h's arithmetic with a fresh expf).
    const float loss_W = i * i * hpddo::ra_at_ohm(p, 30.0f + rise);
    const float target_K = p.th_r_K_per_W * loss_W;
    float next = target_K + (rise - target_K) * expf(-dt / p.th_tau_s);
    if (next > hpddo::kWindingMax_C - 30.0f) next = hpddo::kWindingMax_C - 30.0f;
    if (!(next >= 0.0f)) next = 0.0f;
    rise = next;
    ASSERT_EQ(cached.rise_K(), rise) << "step " << k;
  }
}

TEST(Thermal, SettlesAtTheSelfConsistentSteadyState) {
  const hpddo::PhysicsParams p = params();
  hpddo::ThermalEstimator t;
  for (int k = 0; k < 20000; ++k) t.step(p, 1.0f, 0.5f, 30.0f);
  // T = Tamb + r i^2 Ra (1 + a (T - Tref))  ->  rise = r Ra / (1 - r Ra a)
  const double rise = 8.0 * 4.5 / (1.0 - 8.0 * 4.5 * 0.00393);
  EXPECT_NEAR(t.temp_C(30.0f), 30.0 + rise, 0.05);
}

TEST(Thermal, TheWindingRisesAboveAMovingReference) {
  // Above a case reading the rise is the same node: a case 20 K warmer makes the copper
  // (and so the loss, and so the rise) a little higher, and the winding 20 K + that warmer.
  const hpddo::PhysicsParams p = params();
  hpddo::ThermalEstimator cold, warm;
  for (int k = 0; k < 20000; ++k) {
    cold.step(p, 1.0f, 0.5f, 30.0f);
    warm.step(p, 1.0f, 0.5f, 50.0f);
  }
  EXPECT_GT(warm.rise_K(), cold.rise_K());
  EXPECT_NEAR(warm.rise_K() - cold.rise_K(), 8.0 * 4.5 * 0.00393 * 20.0 / (1.0 - 8.0 * 4.5 * 0.00393), 0.05);
  EXPECT_NEAR(warm.temp_C(50.0f) - cold.temp_C(30.0f), 20.0f + warm.rise_K() - cold.rise_K(), 1e-4);
}

TEST(Thermal, ResetReturnsToTheReference) {
  const hpddo::PhysicsParams p = params();
  hpddo::ThermalEstimator t;
  t.step(p, 1.0f, 100.0f, 30.0f);
  EXPECT_GT(t.temp_C(30.0f), 30.0f);
  t.reset();
  EXPECT_EQ(t.temp_C(30.0f), 30.0f);
  EXPECT_EQ(t.rise_K(), 0.0f);
}
