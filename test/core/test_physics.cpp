#include <cmath>

#include <gtest/gtest.h>

#include "hpddo/physics.h"
#include "motor.h"

namespace {

hpddo::PhysicsParams plain() { return motor::plain(31.0f); }

hpddo::PhysicsInput at(float v_V, float i_A, float temp_C = 31.0f, float di_dt = 0.0f) {
  hpddo::PhysicsInput in = {v_V, i_A, di_dt, temp_C, temp_C};
  return in;
}

float rpm(const hpddo::PhysicsParams& p, const hpddo::PhysicsInput& in) {
  float n = -1.0f;
  EXPECT_TRUE(hpddo::physics_rpm(p, in, &n));
  return n;
}

}  // namespace

TEST(Physics, PlainBackEmfModel) {
  // (9.6 V - 0.8 A * 4.5 ohm) / 0.406 V s/rad = 14.7783 rad/s = 141.122 RPM
  EXPECT_NEAR(rpm(plain(), at(9.6f, 0.8f)), 6.0 / 0.406 * 60.0 / (2.0 * M_PI), 1e-3);
}

TEST(Physics, NameplateKeIsRatedVoltageOverRatedSpeed) {
  EXPECT_NEAR(hpddo::nameplate_ke_vs_per_rad(12.0f, 1000.0f), 12.0 / (1000.0 * 2.0 * M_PI / 60.0), 1e-6);
  const hpddo::PhysicsParams m1 = hpddo::nameplate_params(4.5f, 12.0f, 1000.0f);
  EXPECT_EQ(m1.effects, 0u);
  EXPECT_NEAR(rpm(m1, at(12.0f, 0.0f)), 1000.0, 1e-2);
}

TEST(Physics, ThermalRaRaisesResistanceWithTemperature) {
  hpddo::PhysicsParams p = plain();
  p.ra_tc_per_K = 0.00393f;
  EXPECT_NEAR(hpddo::ra_at_ohm(p, 71.0f), 4.5 * (1.0 + 0.00393 * 40.0), 1e-5);
  // Hotter winding: more of V is resistive drop, so less speed for the same V and I.
  EXPECT_LT(rpm(p, at(9.6f, 0.8f, 71.0f)), rpm(p, at(9.6f, 0.8f, 31.0f)));
}

TEST(Physics, MagnetThermalLowersKeSoSameEmfMeansMoreSpeed) {
  hpddo::PhysicsParams p = plain();
  p.ke_tc_per_K = -0.002f;
  EXPECT_NEAR(hpddo::ke_at_vs_per_rad(p, 71.0f, 0.0f), 0.406 * (1.0 - 0.08), 1e-6);
  EXPECT_GT(rpm(p, at(9.6f, 0.8f, 71.0f)), rpm(p, at(9.6f, 0.8f, 31.0f)));
}

TEST(Physics, BrushDropIsOddAndSaturates) {
  hpddo::PhysicsParams p = plain();
  p.brush_V = 1.0f;
  p.brush_knee_A = 0.02f;  // the library's base form
  EXPECT_EQ(hpddo::brush_drop_V(p, 0.0f), 0.0f);
  EXPECT_NEAR(hpddo::brush_drop_V(p, 0.02f), 0.5, 1e-6);  // half at the knee
  EXPECT_NEAR(hpddo::brush_drop_V(p, 2.0f), 2.0 / 2.02, 1e-6);
  EXPECT_NEAR(hpddo::brush_drop_V(p, -2.0f), -2.0 / 2.02, 1e-6);
  const float plain_n = rpm(plain(), at(9.6f, 0.8f));
  EXPECT_NEAR(plain_n - rpm(p, at(9.6f, 0.8f)), 0.8 / 0.82 / 0.406 * 60.0 / (2.0 * M_PI), 1e-2);
}

TEST(Physics, SaturationLowersKeWithCurrentMagnitude) {
  hpddo::PhysicsParams p = plain();
  p.ke_sat_per_A = 0.05f;
  EXPECT_NEAR(hpddo::ke_at_vs_per_rad(p, 31.0f, 2.0f), 0.406 * 0.9, 1e-6);
  EXPECT_NEAR(hpddo::ke_at_vs_per_rad(p, 31.0f, -2.0f), 0.406 * 0.9, 1e-6);
}

TEST(Physics, SaturationShapeRunsFromLinearToQuadratic) {
  hpddo::PhysicsParams p = plain();
  p.ke_sat_per_A = 0.05f;
  p.ke_sat_quad = 1.0f;  // Ke (1 - s i^2 / 1 A)
  EXPECT_NEAR(hpddo::ke_at_vs_per_rad(p, 31.0f, 2.0f), 0.406 * (1.0 - 0.05 * 4.0), 1e-6);
  EXPECT_NEAR(hpddo::ke_at_vs_per_rad(p, 31.0f, -0.5f), 0.406 * (1.0 - 0.05 * 0.25), 1e-6);
  p.ke_sat_quad = 0.5f;  // half of each
  EXPECT_NEAR(hpddo::ke_at_vs_per_rad(p, 31.0f, 2.0f), 0.406 * (1.0 - 0.05 * 2.0 * 1.5), 1e-6);
}

TEST(Physics, BrushKneeSetsWhereTheDropSwitchesOn) {
  hpddo::PhysicsParams p = plain();
  p.brush_V = 1.0f;
  p.brush_knee_A = 0.1f;
  EXPECT_NEAR(hpddo::brush_drop_V(p, 0.1f), 0.5, 1e-6);
  EXPECT_NEAR(hpddo::brush_drop_V(p, -0.3f), -0.75, 1e-6);
  p.brush_knee_A = 0.0f;  // below the minimum knee (and NaN): the minimum
  EXPECT_NEAR(hpddo::brush_drop_V(p, hpddo::kBrushKneeMin_A), 0.5, 1e-6);
  p.brush_knee_A = NAN;
  EXPECT_NEAR(hpddo::brush_drop_V(p, hpddo::kBrushKneeMin_A), 0.5, 1e-6);
  EXPECT_EQ(hpddo::brush_drop_V(p, 0.0f), 0.0f);
}

TEST(Physics, BrushOrderSetsHowSharplyTheDropLevelsOff) {
  hpddo::PhysicsParams p = plain();
  p.brush_V = 1.0f;
  p.brush_knee_A = 0.2f;
  p.brush_order = 1.0f;  // the base form, the same float as i / (|i| + knee)
  EXPECT_EQ(hpddo::brush_drop_V(p, 0.3f), 1.0f * 0.3f / (0.3f + 0.2f));
  p.brush_order = NAN;   // below 1 (and NaN): the base form
  EXPECT_EQ(hpddo::brush_drop_V(p, 0.3f), 1.0f * 0.3f / (0.3f + 0.2f));
  p.brush_order = 2.0f;  // i / sqrt(i^2 + knee^2)
  EXPECT_NEAR(hpddo::brush_drop_V(p, 0.2f), 1.0 / std::sqrt(2.0), 1e-6);
  EXPECT_NEAR(hpddo::brush_drop_V(p, -0.6f), -0.6 / std::sqrt(0.36 + 0.04), 1e-6);
  p.brush_order = 1.5f;  // half way between the base form and order 2
  EXPECT_NEAR(hpddo::brush_drop_V(p, 0.2f), 0.5 * (0.5 + 1.0 / std::sqrt(2.0)), 1e-6);
  EXPECT_EQ(hpddo::brush_drop_V(p, 0.0f), 0.0f);
}

TEST(Physics, VoltageOffsetIsRemovedBeforeTheGain) {
  hpddo::PhysicsParams p = plain();
  p.v_offset_V = 0.1f;
  p.v_gain = 0.02f;
  EXPECT_NEAR(hpddo::true_voltage_V(p, 9.892f), 9.6, 1e-5);  // 9.6 (1 + 0.02) + 0.1
  EXPECT_NEAR(rpm(p, at(9.892f, 0.8f)), rpm(plain(), at(9.6f, 0.8f)), 1e-2);
}

TEST(Physics, SensorErrorsAreRemovedFromTheReadings) {
  hpddo::PhysicsParams p = plain();
  p.i_offset_A = 0.05f;
  p.v_gain = 0.02f;
  EXPECT_NEAR(hpddo::true_current_A(p, 0.85f), 0.8, 1e-6);
  EXPECT_NEAR(hpddo::true_voltage_V(p, 9.792f), 9.6, 1e-5);
  EXPECT_NEAR(rpm(p, at(9.792f, 0.85f)), rpm(plain(), at(9.6f, 0.8f)), 1e-2);
}

TEST(Physics, CurrentOffsetDriftFollowsTheCaseTemperature) {
  // current_offset_drift: the offset i_offset + c (T_case - t_ref), the case as magnet_C; at
  // t_ref only the constant offset, 10 K warmer 10 c more, at every current and at zero
  hpddo::PhysicsParams p = plain();  // t_ref 31 C
  p.i_offset_A = 0.01f;
  p.i_offset_tc_A_per_K = 0.001f;
  EXPECT_NEAR(hpddo::true_current_A(p, 0.85f, 31.0f), 0.84, 1e-6);
  EXPECT_NEAR(hpddo::true_current_A(p, 0.85f, 41.0f), 0.83, 1e-6);
  EXPECT_NEAR(hpddo::true_current_A(p, 0.0f, 41.0f), -0.02, 1e-6);
  hpddo::PhysicsInput warm = at(9.6f, 0.82f, 31.0f);
  warm.magnet_C = 41.0f;  // the winding at t_ref, the case 10 K warmer: the drift follows the case
  hpddo::PhysicsParams q = plain();
  EXPECT_NEAR(rpm(p, warm), rpm(q, at(9.6f, 0.80f)), 1e-2);
  p.i_offset_tc_A_per_K = 0.0f;  // off: the constant offset only, whatever the case
  EXPECT_EQ(rpm(p, warm), rpm(p, at(9.6f, 0.82f)));
}

TEST(Physics, InductanceSubtractsLdiDt) {
  hpddo::PhysicsParams p = plain();
  p.la_H = 0.004f;
  // di/dt = 100 A/s -> 0.4 V less back-EMF
  const float d = rpm(plain(), at(9.6f, 0.8f)) - rpm(p, at(9.6f, 0.8f, 31.0f, 100.0f));
  EXPECT_NEAR(d, 0.4 / 0.406 * 60.0 / (2.0 * M_PI), 1e-2);
}

TEST(Physics, NonPositiveKeOrNonFiniteResultIsRefused) {
  hpddo::PhysicsParams p = plain();
  p.ke_sat_per_A = 1.0f;  // Ke reaches zero at 1 A
  float n = 123.0f;
  EXPECT_FALSE(hpddo::physics_rpm(p, at(9.6f, 1.0f), &n));
  EXPECT_FALSE(hpddo::physics_rpm(p, at(9.6f, 1.5f), &n));
  EXPECT_FALSE(hpddo::physics_rpm(plain(), at(NAN, 0.5f), &n));
  EXPECT_FALSE(hpddo::physics_rpm(plain(), at(9.6f, INFINITY), &n));
  EXPECT_EQ(n, 123.0f);
}
