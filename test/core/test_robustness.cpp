// Reliability of the observer under held extreme and adversarial readings: every
// state stays bounded and physical, every estimate finite and within the model's
// physical speed range, and the observer recovers by itself when readings return
// to normal. The bounds are written here from their physical meaning
// (docs/core.md, "Bounds"), not read from the code under test.
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "hpddo_core.h"
#include "model_tiny.h"
#include "model_tiny1.h"
#if defined(HPDDO_HAVE_DEFAULT_MODEL)
#include "model_default.h"
#endif

namespace {

/// The hottest a winding may be: the 250 C thermal class of IEC 60085.
const float kHottest_C = 250.0f;

/// Largest |n_M2| the model's own limits allow (docs/core.md): four times the
/// speed at which Ke would balance v_max plus i_max Ra.
template <class Net>
float speed_bound_rpm(const hpddo::Model<Net>& m) {
  const double e = static_cast<double>(m.limits.v_max_V) +
                   static_cast<double>(m.limits.i_max_A) * static_cast<double>(m.physics.ra_ohm);
  return static_cast<float>(4.0 * e / static_cast<double>(m.physics.ke_vs_per_rad) * 60.0 / (2.0 * M_PI) * 1.0001);
}

hpddo::Sample make(float v, float i, float temp, float dt, uint16_t seq, bool has_seq = true) {
  const hpddo::Sample s = {v, i, temp, dt, seq, has_seq};  // the fields in their declared order
  return s;
}

/// Checks one estimate against the physical bounds; returns false on the first fault.
template <class Net>
bool bounded(const hpddo::Model<Net>& m, const hpddo::Estimate& e, std::string* why) {
  const float n_max = speed_bound_rpm(m);
  char buf[200];
  if (!hpddo::is_finite(e.rpm) || !hpddo::is_finite(e.rpm_m2) || !hpddo::is_finite(e.residual_rpm) ||
      !hpddo::is_finite(e.temp_C)) {
    std::snprintf(buf, sizeof buf, "not finite: rpm %g m2 %g res %g T %g", static_cast<double>(e.rpm),
                  static_cast<double>(e.rpm_m2), static_cast<double>(e.residual_rpm), static_cast<double>(e.temp_C));
    *why = buf;
    return false;
  }
  if (std::fabs(e.rpm_m2) > n_max || std::fabs(e.rpm) > n_max + m.clamp_rpm) {
    std::snprintf(buf, sizeof buf, "speed beyond %g: rpm %g m2 %g", static_cast<double>(n_max),
                  static_cast<double>(e.rpm), static_cast<double>(e.rpm_m2));
    *why = buf;
    return false;
  }
  // The winding: never hotter than the insulation allows, never colder than the
  // coldest reference the observer can use (the sensor's range or the ambient).
  const float coldest = std::fmin(m.limits.temp_min_C, m.physics.t_amb_C);
  if (e.temp_C > kHottest_C || e.temp_C < coldest - 1.0f) {
    std::snprintf(buf, sizeof buf, "winding at %g C", static_cast<double>(e.temp_C));
    *why = buf;
    return false;
  }
  if (std::fabs(e.residual_rpm) > m.clamp_rpm) {
    *why = "residual beyond the clamp";
    return false;
  }
  return true;
}

/// What a held extreme reading looks like, sample k.
enum Held { kFullScale, kZero, kNegFullScale, kAlternating, kNanBursts, kTempOutOfRange, kHeldCount };
const char* held_name(int h) {
  static const char* n[] = {"full-scale current", "zero", "negative full scale", "alternating", "NaN bursts",
                            "temperature out of range"};
  return n[h];
}

template <class Net>
hpddo::Sample held_sample(const hpddo::Model<Net>& m, int h, long k, float dt) {
  const float vmax = m.limits.v_max_V, imax = m.limits.i_max_A;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const uint16_t seq = static_cast<uint16_t>(k);
  switch (h) {
    case kFullScale: return make(vmax, imax, 40.0f, dt, seq);
    case kZero: return make(0.0f, 0.0f, 40.0f, dt, seq);
    case kNegFullScale: return make(-vmax, -imax, nan, dt, seq);
    case kAlternating: return (k & 1) ? make(vmax, imax, 125.0f, dt, seq) : make(-vmax, -imax, -55.0f, dt, seq);
    case kNanBursts: return (k % 7 < 3) ? make(nan, nan, nan, dt, seq) : make(vmax, imax, nan, dt, seq);
    default: return make(vmax, imax, (k & 1) ? 900.0f : -300.0f, dt, seq);
  }
}

/// Holds each extreme for hours_extreme, then normal readings for hours_normal: every
/// estimate bounded, the status back to ok/clamped/fallback, and the winding back
/// within 0.5 K of an observer that saw only the normal readings for as long.
template <class Net>
void held_extremes(const hpddo::Model<Net>& m, const char* name, float rate_hz, double hours_extreme,
                   double hours_normal) {
  const float dt = 1.0f / rate_hz;
  const long n_ext = static_cast<long>(hours_extreme * 3600.0 * static_cast<double>(rate_hz));
  const long n_norm = static_cast<long>(hours_normal * 3600.0 * static_cast<double>(rate_hz));
  const bool thermal = hpddo::ThermalEstimator::enabled(m.physics);
  for (int h = 0; h < kHeldCount; ++h) {
    hpddo::Observer<Net> obs(m);
    hpddo::Observer<Net> calm(m);
    std::string why;
    long k = 0;
    for (; k < n_ext; ++k) {
      const hpddo::Estimate e = obs.step(held_sample(m, h, k, dt));
      if (!bounded(m, e, &why)) {
        ADD_FAILURE() << name << " at " << rate_hz << " Hz, held " << held_name(h) << ", sample " << k << ": "
                      << why;
        break;
      }
    }
    if (k < n_ext) continue;
    hpddo::Estimate e = hpddo::Estimate(), c = hpddo::Estimate();
    for (long j = 0; j < n_norm; ++j, ++k) {
      const hpddo::Sample s = make(9.6f, 0.9f, 40.0f, dt, static_cast<uint16_t>(k));
      e = obs.step(s);
      c = calm.step(s);
      if (!bounded(m, e, &why)) {
        ADD_FAILURE() << name << ", held " << held_name(h) << ", normal sample " << j << ": " << why;
        break;
      }
      if (j >= 2 && e.status == hpddo::kStatusInvalid) {
        ADD_FAILURE() << name << ", held " << held_name(h) << ": still invalid " << j << " samples after";
        break;
      }
    }
    EXPECT_NE(e.status, hpddo::kStatusInvalid) << name << ", held " << held_name(h);
    if (thermal) {
      EXPECT_NEAR(e.temp_C, c.temp_C, 0.5f) << name << ", held " << held_name(h) << " at " << rate_hz;
    }
  }
}

}  // namespace

TEST(Robustness, HeldExtremesFourHoursAt2Hz) {
  held_extremes(hpddo_model_tiny::kModel, "tiny", 2.0f, 4.0, 4.0);
  held_extremes(hpddo_model_tiny1::kModel, "tiny1", 2.0f, 4.0, 4.0);
#if defined(HPDDO_HAVE_DEFAULT_MODEL)
  held_extremes(hpddo_model_default::kModel, "default", 2.0f, 4.0, 1.0);
#endif
}

TEST(Robustness, HeldExtremesFourHoursAt100Hz) {
  held_extremes(hpddo_model_tiny::kModel, "tiny", 100.0f, 4.0, 3.0);
#if defined(HPDDO_HAVE_DEFAULT_MODEL)
  held_extremes(hpddo_model_default::kModel, "default", 100.0f, 4.0, 0.1);
#endif
}

TEST(Robustness, FullScaleCurrentKeepsTheWindingBelowTheInsulationLimit) {
  // The probe's case: thermal_ra, magnet_thermal and current_offset on, a current held
  // at full scale at 2 Hz. Copper's Ra(T) heats the winding faster than it cools
  // (thermal runaway of the model); the estimate must stay usable all along.
  using Net = hpddo_model_tiny::Net;
  hpddo::Observer<Net> obs(hpddo_model_tiny::kModel);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int k = 0; k < 2000; ++k) {
    const hpddo::Estimate e = obs.step(make(12.0f, 10.0f, nan, 0.5f, static_cast<uint16_t>(k)));
    ASSERT_LE(e.temp_C, kHottest_C) << "sample " << k;
    ASSERT_NE(e.status, hpddo::kStatusInvalid) << "sample " << k;
  }
}

TEST(Robustness, DenormalPeriodOnAGoodSampleIsNotInvalid) {
  using Net = hpddo_model_tiny::Net;
  hpddo::Observer<Net> obs(hpddo_model_tiny::kModel);
  obs.step(make(9.0f, 0.8f, 40.0f, 0.5f, 1));
  const float periods[] = {1e-40f, 1e-45f, 1e-38f, 1e-20f, 1e-9f, 1e-6f};
  uint16_t seq = 2;
  for (float dt : periods) {
    const hpddo::Estimate e = obs.step(make(9.2f, 0.85f, 40.0f, dt, seq++));
    EXPECT_NE(e.status, hpddo::kStatusInvalid) << "dt " << dt;
    std::string why;
    EXPECT_TRUE(bounded(hpddo_model_tiny::kModel, e, &why)) << "dt " << dt << ": " << why;
  }
}

TEST(Robustness, TinyPeriodsNeverGiveAbsurdSpeeds) {
  // With the inductance effect, la di/dt over a period of 1e-38..1e-3 s was up to 1e36 RPM.
  using Net = hpddo_model_tiny::Net;
  const hpddo::Model<Net>& m = hpddo_model_tiny::kModel;
  for (float dt = 1e-38f; dt < 1e-2f; dt *= 3.7f) {
    hpddo::Observer<Net> obs(m);
    obs.step(make(9.0f, -m.limits.i_max_A, 40.0f, 0.5f, 1));
    const hpddo::Estimate e = obs.step(make(9.0f, m.limits.i_max_A, 40.0f, dt, 2));
    std::string why;
    EXPECT_TRUE(bounded(m, e, &why)) << "dt " << dt << ": " << why;
    const hpddo::Estimate next = obs.step(make(9.0f, 0.8f, 40.0f, 0.5f, 3));
    EXPECT_NE(next.status, hpddo::kStatusInvalid) << "dt " << dt;
  }
}

TEST(Robustness, SeqJumpOf65536WithALongPeriodStartsANewSegment) {
  // On the 16-bit link seq alone cannot show 65536 lost samples; the period can.
  using Net = hpddo_model_tiny::Net;
  const hpddo::Model<Net>& m = hpddo_model_tiny::kModel;
  hpddo::Observer<Net> a(m), b(m);
  a.step(make(9.0f, 0.5f, 40.0f, 0.5f, 7));
  b.step(make(9.0f, 0.5f, 40.0f, 0.5f, 7));
  b.restart_lags();
  const float long_dt = 65536.0f * 0.5f;
  const hpddo::Estimate ea = a.step(make(10.0f, 1.5f, 40.0f, long_dt, 8));
  const hpddo::Estimate eb = b.step(make(10.0f, 1.5f, 40.0f, long_dt, 8));
  EXPECT_EQ(ea.rpm_m2, eb.rpm_m2);
  EXPECT_EQ(ea.rpm, eb.rpm);
  EXPECT_EQ(ea.status, eb.status);
}

/// Fuzz-style sweep: adversarial V, I, temperature, period and seq; every output finite,
/// bounded, and the observer never stuck (a normal sample after any burst is not invalid
/// by the second sample).
template <class Net>
void adversarial_sweep(const hpddo::Model<Net>& m, const char* name, uint32_t seed, int bursts) {
  std::mt19937 rng(seed);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const float vmax = m.limits.v_max_V, imax = m.limits.i_max_A;
  const float big = std::numeric_limits<float>::max(), tiny = std::numeric_limits<float>::denorm_min();
  const float vs[] = {0.0f, vmax, -vmax, vmax * 0.999f, -vmax * 0.999f, 1e-40f, -1e-40f, tiny, nan, inf, -inf,
                      big, 9.6f, 12.0f, 2.0f, vmax * 1.001f};
  const float is[] = {0.0f, imax, -imax, imax * 0.999f, -imax * 0.999f, 1e-40f, -1e-40f, nan, inf, -inf, big,
                      0.9f, 1.9f, -0.05f, 0.012f, imax * 1.001f};
  const float ts[] = {nan, -55.0f, 125.0f, -55.1f, 125.1f, 300.0f, -300.0f, inf, -inf, 40.0f, 1e30f, 0.0f};
  const float dts[] = {1e-40f, tiny, 1e-38f, 1e-30f, 1e-12f, 1e-7f, 1e-6f, 9.9e-6f, 1e-5f, 1.1e-5f, 1e-4f,
                       1e-3f, 0.01f, 0.5f, 2.0f, 10.0f, 11.0f, 3600.0f, 32768.0f, 1e10f, 1e30f, big, 0.0f,
                       -0.5f, -tiny, nan, inf};
  auto pick = [&](const float* a, size_t n) { return a[rng() % n]; };
  hpddo::Observer<Net> obs(m);
  uint16_t seq = 0;
  std::string why;
  for (int b = 0; b < bursts; ++b) {
    const int len = 1 + static_cast<int>(rng() % 40);
    for (int k = 0; k < len; ++k) {
      hpddo::Sample s;
      const uint32_t r = static_cast<uint32_t>(rng());
      s.v_V = (r & 3) ? pick(vs, sizeof vs / sizeof vs[0]) : std::uniform_real_distribution<float>(-vmax, vmax)(rng);
      s.i_A = (r & 12) ? pick(is, sizeof is / sizeof is[0]) : std::uniform_real_distribution<float>(-imax, imax)(rng);
      s.temp_C = pick(ts, sizeof ts / sizeof ts[0]);
      s.dt_s = (r & 48) ? pick(dts, sizeof dts / sizeof dts[0])
                        : std::exp(std::uniform_real_distribution<float>(-90.0f, 30.0f)(rng));
      switch ((r >> 6) % 5) {
        case 0: seq = static_cast<uint16_t>(seq + 1u); break;
        case 1: seq = static_cast<uint16_t>(seq + 1u); break;  // + 65536: the same on 16 bits
        case 2: seq = static_cast<uint16_t>(rng()); break;
        case 3: break;                                          // repeated
        default: break;
      }
      s.seq = seq;
      s.has_seq = ((r >> 6) % 5) != 4;
      const hpddo::Estimate e = obs.step(s);
      if (!bounded(m, e, &why)) {
        ADD_FAILURE() << name << " burst " << b << " sample " << k << " (v " << s.v_V << ", i " << s.i_A << ", T "
                      << s.temp_C << ", dt " << s.dt_s << "): " << why;
        return;
      }
    }
    hpddo::Estimate e;
    for (int k = 0; k < 2; ++k) {
      seq = static_cast<uint16_t>(seq + 1u);
      e = obs.step(make(9.6f, 0.9f, 40.0f, 0.5f, seq));
      if (!bounded(m, e, &why)) {
        ADD_FAILURE() << name << " burst " << b << ", recovery: " << why;
        return;
      }
    }
    if (e.status == hpddo::kStatusInvalid) {
      ADD_FAILURE() << name << " stuck invalid after burst " << b;
      return;
    }
  }
}

TEST(Robustness, AdversarialSweepTiny) { adversarial_sweep(hpddo_model_tiny::kModel, "tiny", 1u, 20000); }
TEST(Robustness, AdversarialSweepTiny1) { adversarial_sweep(hpddo_model_tiny1::kModel, "tiny1", 2u, 5000); }
#if defined(HPDDO_HAVE_DEFAULT_MODEL)
TEST(Robustness, AdversarialSweepDefault) {
  adversarial_sweep(hpddo_model_default::kModel, "default", 3u, 5000);
}
#endif
