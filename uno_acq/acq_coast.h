// The coast probe of the ripple mode (issue 33, item 7; docs/ripple-coast.md, docs/ripple-board.md
// "Coast probes"): the drive held off for a few milliseconds so that the open terminals show the
// back-EMF itself, Ke times the speed. Pure logic (how many samples, which channel, how often, the
// chunk's kind); the registers are in acq_ripple_board.h.
//
// A probe takes a window's burst's place (the window's last periods): at the burst's first period
// the PWM output is held low (the bridge freewheels through its diode), and each period's
// triggered conversion (Timer1 compare B, as the burst's) takes the current and the terminal
// voltage in turn, current first: sample k is the current where k is even, the voltage where it is
// odd. Alternating, not the current then the voltage, because the estimator needs both through
// the decay: the charge the freewheel still carries (the current, until it reads zero) and the
// voltage from the first sample after it (ripple/coast.py back_emf), and the decay's length depends
// on the current and the back-EMF (0.3 ms on the twin's motor, more on a larger inductance): a
// fixed split would either waste the probe on zeros or miss the decay's end. One converter cannot
// take both channels in one period at 10 kHz (a triggered conversion is 432 cycles of the 1600, and
// a second one would end past the period for duties above 0.6), so each channel gets half the
// rate: the bench log's coast file says exactly this (docs/bench-log.md, "Coast probes": current
// sample j at t_s + 2 j / sample_hz, voltage sample j at t_s + (2 j + 1) / sample_hz).
//
// The samples go in chunks of the ripple chunk's layout (acq_ripple.h) with sync1 kCoastSync1;
// `total` is the probe's sample count, codes in the order taken. The drive comes back at the
// period after the probe's last; the rest of the window has no burst (the shaft recovers there),
// and the window's V and I means (its first 20 %) were taken before the cut.
#ifndef HPDDO_ACQ_COAST_H
#define HPDDO_ACQ_COAST_H

#include <stdint.h>

#include "acq_config.h"
#include "acq_ripple.h"

namespace acq {

static const uint8_t kCoastSync1 = 0x5C;  ///< a coast probe's chunk (0x5B a ripple burst's, 0x5A a sample frame)
/// The drive held off per probe, us: the twin's COAST_PROBE probe_s (tools/hpddo/twin/params.py;
/// test/py/test_ripple_coast_board.py holds the two equal): the current freewheels to zero within
/// about 0.5 ms, the rest shows the back-EMF, short against the shaft's mechanical time constant.
/// Whole microseconds and milliseconds: the arithmetic below is in integers, 16-bit where it fits
/// (docs/ripple-board.md, "Coast probes": each step of making the probe smaller, measured).
static const uint32_t kCoastProbeUs = 4000;
/// A probe every this many milliseconds once probes are on (`coast 1`): the twin's COAST_PROBE period_s.
static const uint32_t kCoastPeriodMs = 1500;

/// Samples of a probe at the ripple rate (the PWM's, period_cycles a period: TOP + 1, the ripple
/// mode's prescaler is 1): kCoastProbeUs of periods, rounded to an even count (one current and one
/// voltage sample a pair), at least 2 pairs. In 16 bits: half the probe is 32000 cycles.
inline uint16_t coast_samples(uint16_t period_cycles) {
  static const uint16_t kHalfProbeCycles = static_cast<uint16_t>(kCoastProbeUs * (kCpuHz / 1000000u) / 2u);
  const uint16_t pairs = static_cast<uint16_t>((kHalfProbeCycles + period_cycles / 2u) / period_cycles);
  return static_cast<uint16_t>(pairs < 2u ? 4u : 2u * pairs);
}

/// Windows from one probe to the next: kCoastPeriodMs of windows of window_periods periods of
/// period_cycles, rounded, at least 2 (a probe window's neighbours are driven: the estimator counts
/// the speed there).
inline uint16_t coast_every_windows(uint16_t period_cycles, uint16_t window_periods) {
  const uint32_t window = static_cast<uint32_t>(window_periods) * period_cycles;
  const uint32_t n = (kCoastPeriodMs * (kCpuHz / 1000u) + window / 2u) / window;
  return static_cast<uint16_t>(n < 2u ? 2u : (n > 65535u ? 65535u : n));
}

/// Whether a window whose burst holds burst_n samples can carry a probe of probe_n: the probe
/// takes the burst's place, and the drive comes back (at the probe's last period) before the
/// window's last period, where the next window's setpoint is loaded.
inline bool coast_fits(uint16_t burst_n, uint16_t probe_n) { return burst_n > probe_n; }

/// The ADC channel of a probe's sample k: the current first, then the voltage, in turn.
inline uint8_t coast_channel(uint16_t k) { return (k & 1u) ? kAdcChannelV : kAdcChannelI; }

}  // namespace acq

#endif  // HPDDO_ACQ_COAST_H
