#include <cmath>

#include <gtest/gtest.h>

#include "hpddo/thermal.h"

namespace {
hpddo::PhysicsParams params() {
  hpddo::PhysicsParams p = hpddo::PhysicsParams();
  p.ra_ohm = 4.5f;
  p.ke_vs_per_rad = 0.406f;
  p.t_ref_C = 30.0f;
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
