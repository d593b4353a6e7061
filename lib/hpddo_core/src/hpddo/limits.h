// Physical bounds of the observer and the link, declared once: the channel and
// sensor limits a model carries (InputLimits), the hottest winding the thermal
// state may reach, the periods that are sample-to-sample steps, the factor of
// the model's speed range, and the sample rates of the acquisition board
// (whose `rate` command and the link's period check both read them here).
// docs/core.md ("Bounds") gives the physics of each number.
#ifndef HPDDO_LIMITS_H
#define HPDDO_LIMITS_H

#include <stdint.h>

namespace hpddo {

/// Readings outside these limits are not measurements but faults.
struct InputLimits {
  float v_max_V;       ///< largest |v_V| the voltage channel can report, V
  float i_max_A;       ///< largest |i_A| the current channel can report, A
  float temp_min_C;    ///< temperature sensor range, C (outside: treated as absent)
  float temp_max_C;
};

/// Hottest the winding estimate may be, C: the 250 C thermal class, the highest of
/// IEC 60085; no winding insulation survives above it, so no copper runs hotter.
constexpr float kWindingMax_C = 250.0f;

/// Shortest period that is a sample-to-sample step, s: a hundredth of the fastest
/// acquisition window (1 ms); below it la di/dt is not a measurement of anything.
constexpr float kPeriodMin_s = 1e-5f;

/// Longest period over which the one-step lags still describe the motor, s: five
/// times the slowest acquisition window (2 s); a longer one starts a new segment.
constexpr float kPeriodMax_s = 10.0f;

/// The model's speed range is this factor times (v_max + i_max Ra) / Ke: a factor 2
/// for the hottest copper (Ra x 1.86 at 250 C) and 2 for the weakest magnets (Ke x 0.56).
constexpr float kSpeedLimitFactor = 4.0f;

/// Oldest a case temperature reading may be and still stand for the case, ms: the
/// DS18B20 converts once a second and the acquisition board repeats its last reading
/// at every sample until it is this old (two and a half conversions: one failed
/// conversion is bridged); a log read on the host holds its readings as long.
constexpr uint16_t kTempMaxAge_ms = 2500;

/// Sample rates the acquisition board's `rate` command accepts, Hz.
constexpr float kAcqRateMin_Hz = 0.5f;
constexpr float kAcqRateMax_Hz = 1000.0f;

/// Shortest period a frame can carry, us: half the fastest window (rounding a window
/// to whole PWM periods shortens it by at most a third).
constexpr uint32_t kFramePeriodMin_us = static_cast<uint32_t>(500000.0f / kAcqRateMax_Hz);

/// Longest period a frame can carry, us: 1.5 times the slowest window (rounding
/// lengthens it by at most half a PWM period, 16 ms at 31 Hz).
constexpr uint32_t kFramePeriodMax_us = static_cast<uint32_t>(1500000.0f / kAcqRateMin_Hz);

}  // namespace hpddo

#endif  // HPDDO_LIMITS_H
