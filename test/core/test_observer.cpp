#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "golden.h"
#include "golden_tiny.h"
#include "golden_tiny1.h"
#include "model_tiny.h"
#include "model_tiny1.h"

namespace {

template <class Net>
void replay_golden(const hpddo::Model<Net>& model, int count, float (*at)(uint16_t, uint8_t),
                   hpddo::Sample (*sample)(uint16_t)) {
  using namespace hpddo_golden_tiny;  // column indices are the same for every golden table
  hpddo::Observer<Net> obs(model);
  for (int r = 0; r < count; ++r) {
    const auto g = [&](int c) { return at(static_cast<uint16_t>(r), static_cast<uint8_t>(c)); };
    const hpddo::Sample s = sample(static_cast<uint16_t>(r));
    const hpddo::Estimate e = obs.step(s);
    ASSERT_EQ(static_cast<int>(e.status), static_cast<int>(g(kCol_status))) << "row " << r;
    EXPECT_TRUE(hpddo::is_finite(e.rpm)) << "row " << r;
    EXPECT_TRUE(golden::close(e.rpm_m2, g(kCol_rpm_m2))) << "row " << r << " m2 " << e.rpm_m2;
    EXPECT_TRUE(golden::close(e.residual_rpm, g(kCol_residual_rpm))) << "row " << r;
    EXPECT_TRUE(golden::close(e.rpm, g(kCol_rpm))) << "row " << r << " rpm " << e.rpm;
    EXPECT_TRUE(golden::close(e.temp_C, g(kCol_temp_used_C))) << "row " << r << " T " << e.temp_C;
    EXPECT_TRUE(golden::close(e.confidence, g(kCol_confidence))) << "row " << r << " w " << e.confidence;
    EXPECT_TRUE(e.confidence >= 0.0f && e.confidence <= 1.0f) << "row " << r;
  }
}

hpddo::Sample sample(float v, float i, uint16_t seq, float temp = NAN) {
  hpddo::Sample s = {v, i, temp, 0.5f, seq, true};
  return s;
}

/// The tiny model without its thermal network: the lags are then the only state.
hpddo::Model<hpddo_model_tiny::Net> without_thermal_state() {
  hpddo::Model<hpddo_model_tiny::Net> m = hpddo_model_tiny::kModel;
  m.physics.th_r_K_per_W = 0.0f;
  return m;
}

/// The constructor is a constant expression (constexpr, C++11): with a constexpr model the
/// observer is one too, so a global observer of a generated model is constant-initialised, no
/// constructor code (the UNO's g_obs; docs/firmware-internals.md, "Flash room"). This does not compile
/// if a member leaves the constructor's constant expression.
constexpr hpddo::Model<hpddo_model_tiny::Net> kConstModel = {
    {4.5f, 0.4f, 25.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.05f, 0.0f, 0.0f, 0.0f, 0.02f, 1.0f, 0.0f, 6.0f, 900.0f, 25.0f, 0},
    {}, {}, {}, {}, 100.0f, {40.0f, 10.0f, -55.0f, 125.0f}};
constexpr hpddo::Observer<hpddo_model_tiny::Net> kConstObserver(kConstModel);

}  // namespace

TEST(Observer, TwoLayerModelMatchesGoldenStream) {
  using namespace hpddo_golden_tiny;
  replay_golden(hpddo_model_tiny::kModel, kCount, at, sample);
}

TEST(Observer, OneLayerModelMatchesGoldenStream) {
  using namespace hpddo_golden_tiny1;
  replay_golden(hpddo_model_tiny1::kModel, kCount, at, sample);
}

TEST(Observer, GoldenStreamsReachEveryStatus) {
  using namespace hpddo_golden_tiny;
  int seen[5] = {0, 0, 0, 0, 0};
  int faded = 0;  // gated with a weight strictly between 0 and 1
  for (int r = 0; r < kCount; ++r) {
    ++seen[static_cast<int>(at(static_cast<uint16_t>(r), static_cast<uint8_t>(kCol_status)))];
    const float w = at(static_cast<uint16_t>(r), static_cast<uint8_t>(kCol_confidence));
    faded += w > 0.0f && w < 1.0f;
  }
  for (int s = 0; s < 5; ++s) EXPECT_GT(seen[s], 0) << hpddo::status_name(static_cast<hpddo::Status>(s));
  EXPECT_GT(faded, 0);
}

TEST(Observer, GateScalesTheClampedResidualAndSkipsTheNetworkAtZero) {
  using namespace hpddo_golden_tiny;
  using Net = hpddo_model_tiny::Net;
  hpddo::Observer<Net> obs(hpddo_model_tiny::kModel);
  int checked = 0;
  for (int r = 0; r < kCount; ++r) {
    const auto g = [&](int c) { return at(static_cast<uint16_t>(r), static_cast<uint8_t>(c)); };
    const hpddo::Observer<Net>::Prepared p = obs.prepare(sample(static_cast<uint16_t>(r)));
    if (p.physics.status == hpddo::kStatusInvalid) {
      obs.finish(p, 0.0f);
      continue;
    }
    EXPECT_EQ(p.use_network, p.confidence > 0.0f) << "row " << r;
    EXPECT_TRUE(golden::close(p.confidence, g(kCol_confidence))) << "row " << r;
    if (p.use_network) {
      float clamped = obs.residual(p);
      hpddo::clamp_residual(hpddo_model_tiny::kModel.clamp_rpm, &clamped);
      const hpddo::Estimate e = obs.finish(p, obs.residual(p));
      EXPECT_EQ(e.residual_rpm, p.confidence * clamped) << "row " << r;
      ++checked;
    } else {
      // the network is not needed: any residual given is ignored
      const hpddo::Estimate e = obs.finish(p, 1e6f);
      EXPECT_EQ(e.residual_rpm, 0.0f) << "row " << r;
      EXPECT_EQ(e.rpm, e.rpm_m2) << "row " << r;
    }
  }
  EXPECT_GT(checked, 20);
}

TEST(Observer, BadReadingsNeverGiveNan) {
  using Net = hpddo_model_tiny::Net;
  hpddo::Observer<Net> obs(hpddo_model_tiny::kModel);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const float bad[] = {nan, inf, -inf, 1e30f, -1e30f, 41.0f};
  uint16_t seq = 0;
  obs.step(sample(9.0f, 0.8f, seq++));
  for (float b : bad) {
    hpddo::Estimate e = obs.step(sample(b, 0.8f, seq++));
    EXPECT_EQ(e.status, hpddo::kStatusInvalid);
    EXPECT_TRUE(hpddo::is_finite(e.rpm));
    EXPECT_TRUE(hpddo::is_finite(e.rpm_m2));
    e = obs.step(sample(9.0f, b, seq++));
    EXPECT_EQ(e.status, hpddo::kStatusInvalid);
    EXPECT_TRUE(hpddo::is_finite(e.rpm));
    e = obs.step(sample(9.0f, 0.8f, seq++, b));  // a bad temperature is only an absent one
    EXPECT_NE(e.status, hpddo::kStatusInvalid);
    EXPECT_TRUE(hpddo::is_finite(e.rpm));
    hpddo::Sample s = sample(9.0f, 0.8f, seq++);
    s.dt_s = b;
    e = obs.step(s);
    EXPECT_TRUE(hpddo::is_finite(e.rpm));
  }
}

TEST(Observer, InvalidHoldsTheLastEstimateAndResetsLags) {
  using Net = hpddo_model_tiny::Net;
  const hpddo::Model<Net> model = without_thermal_state();
  hpddo::Observer<Net> obs(model);
  const hpddo::Estimate a = obs.step(sample(9.0f, 0.8f, 1, 40.0f));
  const hpddo::Estimate b = obs.step(sample(NAN, 0.8f, 2, 40.0f));
  EXPECT_EQ(b.status, hpddo::kStatusInvalid);
  EXPECT_EQ(b.rpm, a.rpm);
  EXPECT_EQ(b.residual_rpm, 0.0f);
  // After the reset the lags equal the current values, as on the first sample.
  hpddo::Observer<Net> fresh(model);
  const hpddo::Estimate c = obs.step(sample(10.0f, 0.9f, 3, 40.0f));
  const hpddo::Estimate d = fresh.step(sample(10.0f, 0.9f, 3, 40.0f));
  EXPECT_FLOAT_EQ(c.rpm, d.rpm);
}

TEST(Observer, SeqGapResetsLagsAndIsCounted) {
  using Net = hpddo_model_tiny::Net;
  const hpddo::Model<Net> model = without_thermal_state();
  hpddo::Observer<Net> obs(model);
  hpddo::Observer<Net> fresh(model);
  obs.step(sample(9.0f, 0.8f, 10, 40.0f));
  obs.step(sample(9.5f, 0.85f, 11, 40.0f));
  EXPECT_EQ(obs.seq_gaps(), 0u);
  const hpddo::Estimate after_gap = obs.step(sample(10.0f, 0.9f, 15, 40.0f));
  EXPECT_EQ(obs.seq_gaps(), 1u);
  EXPECT_FLOAT_EQ(after_gap.rpm, fresh.step(sample(10.0f, 0.9f, 15, 40.0f)).rpm);
  obs.step(sample(10.0f, 0.9f, 16, 40.0f));
  EXPECT_EQ(obs.seq_gaps(), 1u);
}

TEST(Observer, ResidualNeverExceedsTheClamp) {
  using Net = hpddo_model_tiny::Net;
  hpddo::Observer<Net> obs(hpddo_model_tiny::kModel);
  uint16_t seq = 0;
  for (float v = 0.0f; v <= 13.0f; v += 0.37f) {
    for (float i = -0.1f; i <= 2.0f; i += 0.13f) {
      const hpddo::Estimate e = obs.step(sample(v, i, seq++, 45.0f));
      EXPECT_LE(std::fabs(e.residual_rpm), hpddo_model_tiny::kModel.clamp_rpm);
      if (e.status == hpddo::kStatusFallback) {
        EXPECT_EQ(e.rpm, e.rpm_m2);
      }
    }
  }
}

TEST(Observer, ConstantInitialisedAsConstructedAtRunTime) {
  using Net = hpddo_model_tiny::Net;
  const hpddo::Model<Net> runtime_model = kConstModel;
  const hpddo::Observer<Net> at_run_time(runtime_model);
  EXPECT_EQ(kConstObserver.speed_limit(), at_run_time.speed_limit());
  EXPECT_EQ(kConstObserver.speed_limit(), hpddo::speed_limit_rpm(runtime_model.physics, runtime_model.limits));
  EXPECT_EQ(kConstObserver.seq_gaps(), 0u);
  EXPECT_EQ(kConstObserver.period_breaks(), 0u);
}

TEST(Observer, ConstructedInTheStateResetLeaves) {
  // The constructor sets every member itself (constexpr: no reset() call in it): a fresh
  // observer and one reset after a stream (thermal rise, lags, a held estimate, a seq gap and
  // a period break behind it) give the same estimates, bit for bit, from then on.
  using Net = hpddo_model_tiny::Net;
  hpddo::Observer<Net> used(hpddo_model_tiny::kModel);
  uint16_t seq = 100;
  for (float k = 0.0f; k < 40.0f; k += 1.0f) used.step(sample(9.0f + 0.05f * k, 0.8f + 0.01f * k, seq++, 45.0f));
  used.step(sample(NAN, 0.8f, seq++, 45.0f));
  used.step(sample(9.0f, 0.8f, static_cast<uint16_t>(seq + 5), 45.0f));
  hpddo::Sample slow = sample(9.0f, 0.8f, static_cast<uint16_t>(seq + 6), 45.0f);
  slow.dt_s = 1.0e4f;  // beyond kPeriodMax_s: a period break
  used.step(slow);
  ASSERT_GT(used.seq_gaps(), 0u);
  ASSERT_GT(used.period_breaks(), 0u);
  used.reset();
  hpddo::Observer<Net> fresh(hpddo_model_tiny::kModel);
  EXPECT_EQ(used.seq_gaps(), fresh.seq_gaps());
  EXPECT_EQ(used.period_breaks(), fresh.period_breaks());
  // First an invalid sample: it holds the estimate the constructor / reset() left.
  const hpddo::Sample samples[] = {sample(NAN, 0.8f, 7, 40.0f), sample(9.0f, 0.8f, 8, 40.0f),
                                   sample(9.5f, 0.85f, 9, NAN), sample(10.0f, 0.9f, 12, 40.0f),
                                   sample(11.0f, 1.2f, 13, 40.0f), sample(3.0f, 0.3f, 14, 40.0f)};
  for (const hpddo::Sample& s : samples) {
    const hpddo::Estimate a = used.step(s);
    const hpddo::Estimate b = fresh.step(s);
    EXPECT_EQ(static_cast<int>(a.status), static_cast<int>(b.status)) << "seq " << s.seq;
    EXPECT_EQ(a.rpm, b.rpm) << "seq " << s.seq;
    EXPECT_EQ(a.rpm_m2, b.rpm_m2) << "seq " << s.seq;
    EXPECT_EQ(a.residual_rpm, b.residual_rpm) << "seq " << s.seq;
    EXPECT_EQ(a.temp_C, b.temp_C) << "seq " << s.seq;
    EXPECT_EQ(a.confidence, b.confidence) << "seq " << s.seq;
  }
  EXPECT_EQ(used.seq_gaps(), fresh.seq_gaps());
  EXPECT_EQ(used.period_breaks(), fresh.period_breaks());
}
