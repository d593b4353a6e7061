// host/compare/observers.h: the EKF and the sliding-mode observer of hpddo compare on
// exact quasi-static samples, i = (V - Ke w)/Ra, of a speed that steps.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "observers.h"

namespace {

using hpddo_compare::Ekf;
using hpddo_compare::EkfParams;
using hpddo_compare::Motor;
using hpddo_compare::Smo;
using hpddo_compare::SmoParams;

const Motor kMotor{0.38, 4.5, 0.0, 0.2};  // Ke V s/rad, Ra ohm, B, Tc
constexpr double kDt = 0.5;               // s, the paper's 2 Hz

struct Sample {
  double v_V, i_A, w_rad_s;
};

/// 40 samples per level of a speed that steps 0 -> 20 -> 35 -> 10 rad/s, the current
/// of a load torque that steps with it, the voltage that balances both.
std::vector<Sample> steps() {
  const double levels[] = {0.0, 20.0, 35.0, 10.0};
  const double load_A[] = {0.05, 0.3, 0.6, 0.2};
  std::vector<Sample> out;
  for (int l = 0; l < 4; ++l)
    for (int k = 0; k < 40; ++k) {
      const double w = levels[l], i = load_A[l];
      out.push_back({kMotor.ke_vs_per_rad * w + i * kMotor.ra_ohm, i, w});
    }
  return out;
}

TEST(CompareObservers, EkfTrustingTheMeasurementIsM2Exactly) {
  Ekf ekf(kMotor, EkfParams{1e-5, 1e6, 1e-6, 1e-12});
  const auto s = steps();
  ekf.restart(s[0].v_V, s[0].i_A);
  for (const auto& x : s) EXPECT_NEAR(ekf.step(x.v_V, x.i_A, kDt), x.w_rad_s, 1e-6);
}

TEST(CompareObservers, EkfSettlesOnEveryLevel) {
  Ekf ekf(kMotor, EkfParams{1e-3, 1e-2, 1e-4, 1e-4});  // a filter that trusts its model too
  const auto s = steps();
  ekf.restart(s[0].v_V, s[0].i_A);
  for (size_t k = 0; k < s.size(); ++k) {
    const double w = ekf.step(s[k].v_V, s[k].i_A, kDt);
    if (k % 40 >= 30) {
      EXPECT_NEAR(w, s[k].w_rad_s, 1e-3) << k;  // the last 5 s of each level
    }
    EXPECT_TRUE(std::isfinite(w));
  }
}

// The ripple count as a second measurement: the filter's Ke is 10 % high, so its current
// alone gives a speed 10 % low; a speed measurement it trusts pulls it to the truth, one it
// does not trust (a huge variance) leaves it where the current put it.
TEST(CompareObservers, EkfSpeedMeasurementCorrectsABiasedKe) {
  Motor biased = kMotor;
  biased.ke_vs_per_rad *= 1.1;
  const EkfParams p{1e-3, 1e-2, 1e-4, 1e-4};
  Ekf alone(biased, p), trusting(biased, p), doubting(biased, p);
  const auto s = steps();
  alone.restart(s[0].v_V, s[0].i_A);
  trusting.restart(s[0].v_V, s[0].i_A);
  doubting.restart(s[0].v_V, s[0].i_A);
  for (size_t k = 0; k < s.size(); ++k) {
    const double w_alone = alone.step(s[k].v_V, s[k].i_A, kDt);
    trusting.step(s[k].v_V, s[k].i_A, kDt);
    const double w_trusting = trusting.update_speed(s[k].w_rad_s, 1e-6);
    doubting.step(s[k].v_V, s[k].i_A, kDt);
    const double w_doubting = doubting.update_speed(s[k].w_rad_s, 1e12);
    EXPECT_NEAR(w_trusting, s[k].w_rad_s, 2e-3) << k;
    EXPECT_NEAR(w_doubting, w_alone, 1e-6) << k;
    if (k % 40 >= 30 && s[k].w_rad_s > 0) {
      EXPECT_LT(w_alone, 0.95 * s[k].w_rad_s) << k;  // the bias the measurement removes
    }
  }
}

// Coasting to rest: no voltage, no current, a filter that trusts its model (the current's
// variance 1 A^2). Coulomb friction brings the shaft to rest and keeps it there; held over a
// 0.5 s period it would carry the speed through zero into a limit cycle of +-g Tc.
TEST(CompareObservers, EkfCoulombFrictionStopsTheShaftWithoutReversingIt) {
  Ekf ekf(kMotor, EkfParams{1e-3, 1e-2, 1e-8, 1.0});
  ekf.restart(kMotor.ke_vs_per_rad * 20.0 + 0.3 * kMotor.ra_ohm, 0.3);  // 20 rad/s, loaded
  double w = ekf.step(0.0, 0.0, kDt);
  for (int k = 0; k < 20; ++k) {
    const double next = ekf.step(0.0, 0.0, kDt);
    EXPECT_GE(next * w, 0.0) << k;  // never through zero
    w = next;
  }
  EXPECT_LT(std::fabs(w), 0.1);  // at rest but for the current measurement's small pull
}

TEST(CompareObservers, SmoReachesTheBackEmfWithBoundedSlew) {
  const SmoParams p{1.0, 0.4, 0.0};  // 1 V per sample at most; gain k/(phi Ra) = 0.56 in the layer
  Smo smo(kMotor, p);
  const auto s = steps();
  smo.restart(s[0].v_V, s[0].i_A);
  double prev = 0.0;
  for (size_t k = 0; k < s.size(); ++k) {
    const double w = smo.step(s[k].v_V, s[k].i_A, kDt);
    EXPECT_LE(std::fabs(w - prev), p.k_V / kMotor.ke_vs_per_rad + 1e-9) << k;  // the slew bound
    if (k % 40 >= 35) {
      EXPECT_NEAR(w, s[k].w_rad_s, 1e-6) << k;
    }
    prev = w;
  }
}

TEST(CompareObservers, SmoFilterLagsButKeepsTheLevel) {
  Smo smo(kMotor, SmoParams{2.0, 0.5, 2.0});  // tau 2 s: alpha = 0.2 per sample
  const auto s = steps();
  smo.restart(s[0].v_V, s[0].i_A);
  double w = 0.0;
  for (size_t k = 0; k < 41; ++k) w = smo.step(s[k].v_V, s[k].i_A, kDt);
  EXPECT_LT(w, 20.0 * 0.5);  // one sample after the step to 20 rad/s: well short of it
  for (size_t k = 41; k < 80; ++k) w = smo.step(s[k].v_V, s[k].i_A, kDt);
  EXPECT_NEAR(w, 20.0, 20.0 * std::pow(0.8, 38));  // the filter's remainder after 39 samples
}

TEST(CompareObservers, SmoChattersWithATooThinBoundaryLayer) {
  const SmoParams p{0.5, 1e-4, 0.0};  // gain k/(phi Ra) = 1100 in the layer: it switches
  Smo smo(kMotor, p);
  const auto s = steps();
  smo.restart(s[0].v_V, s[0].i_A);
  double worst = 0.0;
  for (size_t k = 0; k < 80; ++k) {
    const double w = smo.step(s[k].v_V, s[k].i_A, kDt);
    if (k >= 70) worst = std::fmax(worst, std::fabs(w - s[k].w_rad_s));
  }
  EXPECT_GT(worst, 0.1);                                    // never settles
  EXPECT_LE(worst, p.k_V / kMotor.ke_vs_per_rad + 1e-9);    // but stays within one switching step
}

}  // namespace
