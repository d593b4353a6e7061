// The ripple counter on the board (issue 23, item 5): in the ADC interrupt, on each current
// sample of a burst (acq_ripple_board.h), integer filters and a zero-crossing count; in the
// main loop, per window, the ripple frequency, the output speed, and where the count is
// confident the armature resistance Ra = (V - brush drop - Ke w) / I and the winding
// temperature from copper's coefficient (RippleRa). Host reference, the same integer
// arithmetic: tools/hpddo/ripple/board.py; simavr proves the two equal
// (check_uno_ripple.py --count). docs/ripple-board-count.md, "The ripple counter on the board".
//
// Per filtered code x (every other one, 10-bit), all integers, shifts arithmetic, 32 bits (Q8: a shift by 8 is
// a byte move on the AVR; a pole shifted by s does not move for a difference under 2^s
// units, so 16-bit Q4 states stuck up to 8 codes off the mean at s = 7, which a test showed):
//   h   = x << 8                           Q8, h < 2^18
//   l1 += (h - l1) >> k;  l2 += (l1 - l2) >> k     two low-pass poles at fs / (2 pi 2^k)
//   b  += (l2 - b) >> (k + 2);  y = l2 - b          a high-pass pole at a quarter of that, which
//                                                   also takes out the mean current: a band
//   a  += |y| - (a >> 8)                   32 bits: 256 x the mean |y| (0.64 of a sine's amplitude)
//   rising crossing: 512 y > a after 512 y < -a (y beyond half the mean |y|: hysteresis),
//   counted after the settling: cycles and their PWM periods from one rise to the next, across
//   the gaps between bursts where the expected period (the prior) says how many
// k is set per window from the back-EMF prior so that the band's upper corner is near twice
// the expected ripple frequency: the sub-harmonics of rotor asymmetry (f/2, f/3, f/6) fall
// below its lower corner (f/2), the noise above. The count's frequency must then lie within
// kRippleCountPriorTol of the prior, else the window is not confident (an octave or a
// sub-harmonic counted) and Ra is left alone.
#ifndef HPDDO_ACQ_RIPPLE_COUNT_H
#define HPDDO_ACQ_RIPPLE_COUNT_H

#include <math.h>
#include <stdint.h>

#include "hpddo/params_gen.h"
#include "hpddo/physics.h"
#include "ripple_count_gen.h"  // the constants (kRipple...), generated from tools/hpddo/ripple/board.py

namespace acq {

/// The counter's state; the ADC interrupt calls sample() on each burst code.
struct RippleCounter {
  int32_t l1, l2, b, amp;
  uint8_t k;         ///< low-pass shift of this burst (at the decimated rate)
  uint8_t high;      ///< 1 after y rose above +a/2, 0 after it fell below -a/2
  uint8_t odd;       ///< decimation: every other code is filtered
  uint8_t have_last; ///< last_t holds a counted rise
  uint16_t settle;   ///< filtered codes still to settle before a crossing counts
  uint16_t t;        ///< PWM period clock across bursts (wraps)
  uint16_t last_t;   ///< period of the last rise
  uint16_t t15, t25; ///< 1.5 and 2.5 expected ripple periods, in PWM periods (from the prior)
  uint16_t cyc;      ///< ripple cycles counted since the last latch
  uint16_t span;     ///< PWM periods they took
  uint16_t t1;       ///< running mean of the one-period intervals, PWM periods (0: none since the settling)
};

inline void ripple_counter_reset(RippleCounter* c) {
  c->l1 = c->l2 = c->b = c->amp = 0;
  c->k = kRippleLpReset;
  c->high = c->odd = c->have_last = 0;
  c->settle = c->t = c->last_t = c->t15 = c->t25 = c->cyc = c->span = c->t1 = 0;
}

/// A new burst of burst_n codes, gap PWM periods after the last one's end, with low-pass shift k
/// and the expected ripple period t_exp (PWM periods; 0: no prior, nothing counted). The filter
/// states carry over (the mean current changes little between bursts); after a reset the first
/// 8 x 2^(k+2) filtered codes settle them, across bursts, and after a gap longer than the count
/// bridges (2.5 expected periods: the 2 Hz windows' 103 ms) the first 4 x 2^(k+2). After a gap
/// the count bridges, a burst that holds kRippleMinCycles expected periods (counted alone: the
/// 10 Hz windows') lets the band's slowest pole, the high-pass, settle first (2^(k+2) codes): its
/// state, frozen over the gap, moved the first crossing after it by up to 0.3 period (a 10 Hz
/// window 6 % off on the load-steps twin); a shorter burst (100 Hz windows) needs that crossing
/// to bridge the gap.
__attribute__((noinline)) inline void ripple_counter_begin(RippleCounter* c, uint8_t k, uint16_t t_exp, uint16_t gap,
                                                            bool first_burst, uint16_t burst_n = 0) {
  c->k = k;
  c->odd = 0;
  c->t = static_cast<uint16_t>(c->t + gap);
  const uint32_t t15 = (3u * static_cast<uint32_t>(t_exp)) / 2u, t25 = (5u * static_cast<uint32_t>(t_exp)) / 2u;
  c->t15 = static_cast<uint16_t>(t15 > 65535u ? 65535u : t15);
  c->t25 = static_cast<uint16_t>(t25 > 65535u ? 65535u : t25);
  if (first_burst || gap > c->t25) {  // from zero, or after a gap longer than the count bridges
    const uint32_t settle = static_cast<uint32_t>(first_burst ? 8u : 4u) << (k + 2u);
    c->settle = static_cast<uint16_t>(settle > 60000u ? 60000u : settle);
    c->t1 = 0;
  } else if (gap && burst_n >= static_cast<uint32_t>(kRippleMinCycles) * t_exp) {
    c->settle = static_cast<uint16_t>(1u << (k + 2u));
  }
}

/// One current code (the ADC interrupt; docs/ripple-board-count.md, "CPU", has its cycles on the
/// AVR). Every other code is filtered (5 kHz at 10 kHz: 45 codes a cycle at the fastest ripple,
/// 110 Hz), which halves the cost. A rise 1 to 1.5 expected periods after the last counts one cycle,
/// 1.5 to 2.5 two (one fell in a gap between bursts, or its crossing was lost), a longer one
/// none (the gap of a long window): so the count runs across bursts whose gaps are shorter
/// than a ripple period, as at 100 Hz windows.
// Not inlined: the ADC interrupt then saves only the registers of its own paths, and this
// body its own.
__attribute__((noinline)) inline void ripple_counter_sample(RippleCounter* c, uint16_t x) {
  c->t = static_cast<uint16_t>(c->t + 1u);
  c->odd ^= 1u;
  if (!c->odd) return;
  const int32_t h = static_cast<int32_t>(x) << 8;
  const uint8_t k = c->k;
  c->l1 += (h - c->l1) >> k;
  c->l2 += (c->l1 - c->l2) >> k;
  c->b += (c->l2 - c->b) >> (k + 2u);
  const int32_t y = c->l2 - c->b;
  c->amp += (y < 0 ? -y : y) - (c->amp >> kRippleAmpShift);
  const int32_t y9 = y * 512;  // not y << 9: a negative y would be undefined
  if (!c->high) {
    if (y9 > c->amp) {
      c->high = 1;
      if (!c->settle) {
        if (c->have_last) {
          const uint16_t iv = static_cast<uint16_t>(c->t - c->last_t);
          const uint16_t t1 = c->t1;
          if (iv <= c->t15) {
            ++c->cyc;
            c->span = static_cast<uint16_t>(c->span + iv);
            c->t1 = t1 ? static_cast<uint16_t>(t1 + (static_cast<int16_t>(iv - t1) >> kRippleT1Shift)) : iv;
          } else if (iv <= c->t25 && (!t1 || static_cast<uint16_t>((iv >> 1u) > t1 ? (iv >> 1u) - t1 : t1 - (iv >> 1u)) <=
                                                   static_cast<uint16_t>(t1 >> 2u))) {
            c->cyc = static_cast<uint16_t>(c->cyc + 2u);
            c->span = static_cast<uint16_t>(c->span + iv);
          }
        }
        c->last_t = c->t;
        c->have_last = 1;
      }
    }
  } else if (y9 < -c->amp) {
    c->high = 0;
  }
  if (c->settle) --c->settle;
}

// kRippleBandLeadCycles: the main loop's work on a window ends this many cycles after the
// window's close at most (with margin): 85 600 measured at 100 Hz windows (simavr, the counting
// build; docs/ripple-board-count.md, "The ripple counter on the board").

/// Windows between the one whose prior sets a burst's band (on_window, in the main loop after
/// the observer's step) and the burst's window. 1 when the burst opens surely after that work
/// (burst_period periods of period_cycles after the close, at least kRippleBandLeadCycles: 2 and
/// 10 Hz windows); else 2 (100 Hz windows: the burst opens 36 periods, 57 600 cycles, after the
/// close, while the main loop's work on the window before may still run, up to 85 600 cycles
/// in simavr): the band then comes from the prior of the window before the last, whose work
/// ended in the window before, so which prior counts a burst never depends on the main loop's
/// timing, and the host's reference (ripple/board.py band_lag) counts the same.
inline uint8_t ripple_band_lag(uint16_t burst_period, uint32_t period_cycles) {
  return static_cast<uint32_t>(burst_period) * period_cycles >= kRippleBandLeadCycles ? 1u : 2u;
}

/// The low-pass shift for an expected ripple frequency f_hz at fs_hz: two-pole corner near 2 f.
inline uint8_t ripple_lp_shift(float f_hz, float fs_hz) {
  if (!(f_hz > 0.0f)) return 5;
  const float ratio = fs_hz / (6.2831853f * 2.0f * f_hz);  // 2^k
  uint8_t k = kRippleLpMin;
  while (k < kRippleLpMax && static_cast<float>(1u << (k + 1u)) <= ratio * 1.41421356f) ++k;
  return k;
}

/// The ripple frequency of counted cycles over span PWM periods at fs_hz; false without.
inline bool ripple_counter_hz(float cyc, float span, float fs_hz, float* f_hz) {
  if (!(cyc >= 1.0f) || !(span > 0.0f)) return false;
  *f_hz = cyc * fs_hz / span;
  return true;
}

/// The count's span (acq_ripple_board.h on_window; ripple/board.py track): the cycles, their PWM
/// periods, the windows, their two-window current sums (A: the window's current plus the window
/// before's; one short window's mean current aliases the ripple, in opposite sense from one
/// window to the next) and the observer's priors (RPM) of the windows since the last load or
/// voltage step, each older window's weighted by keep = 1 - dt / kRippleCountTauS (none for
/// windows of tau or longer: at 100 Hz windows a burst holds less than a ripple cycle). A
/// steady operating point: Ra |I - I_span| <= kRippleSteadyTol Ke w_span against the span's
/// means, the speed's move at constant voltage. Beyond it (a load or voltage step, which moves
/// the current) the span begins again at that window (its current and prior the new span's
/// first), and the counts of its first kRippleSettleWindows windows are left out (the step's window and the next: the speed settles,
/// and at 100 Hz the next burst is counted in a band set before the step). A burst holding
/// kRippleMinCycles is the count alone; a confident speed needs kRippleMinCycles weighted cycles.
struct RippleSpan {
  float cyc, span, n, i2, rpm;
  float i_last;  ///< the last counted window's current, A
  uint8_t age;   ///< windows since the span began (kRippleSettleWindows at most)
};

/// Ra and the winding temperature from the ripple speed. The first kRippleKeCalS of
/// confident windows calibrate Ke with Ra at the model's reference (the motor is cold, at
/// t_ref_C, when the board starts): Ke = (V - brush drop - I Ra) / w. After that each
/// confident window gives Ra = (V - brush drop - Ke w) / I (one more than kRippleRaGate from
/// the filtered Ra is left out: a glitch of V or I), filtered with kRippleRaTauS, and
/// the winding temperature T = t_ref + (Ra / Ra0 - 1) / copper's coefficient
/// (hpddo::kMaterialThermalRa, generated from tools/hpddo/schema.py). Where the model has
/// magnet_thermal, Ke falls with the magnets' temperature, taken as the winding's: the two
/// are solved together, T - t_ref = (V - Vb - Ke w - I Ra0) / (I Ra0 a + Ke w b).
struct RippleRa {
  float ke_sum;    ///< sum of the calibration windows' Ke, V s/rad
  float ke_cal;    ///< calibrated Ke at t_ref_C and zero current, V s/rad
  float ra_ohm;    ///< filtered Ra, ohm
  float tw_C;      ///< winding temperature, C
  uint8_t n_cal;   ///< calibration windows so far
  bool have;       ///< ra_ohm and tw_C hold values
};

inline void ripple_ra_reset(RippleRa* r) {
  r->ke_sum = r->ke_cal = r->ra_ohm = r->tw_C = 0.0f;
  r->n_cal = 0;
  r->have = false;
}

/// One window with a confident ripple speed rpm (output shaft) and the window's measured V,
/// I and length dt_s; true when r holds Ra and the winding temperature.
__attribute__((noinline)) inline bool ripple_ra_step(const hpddo::PhysicsParams& p, float v_V, float i_A, float rpm, float dt_s,
                           RippleRa* r) {
  const float v = hpddo::true_voltage_V(p, v_V);
  const float i = hpddo::true_current_A(p, i_A);
  if (!(i >= kRippleFloorA) || !(rpm > 0.0f)) return r->have;
  const float w = rpm / hpddo::kRpmPerRadS;
  const float vb = hpddo::brush_drop_V(p, i);
  const float sat = hpddo::ke_at_vs_per_rad(p, p.t_ref_C, i) / p.ke_vs_per_rad;  // armature reaction at i
  const float cal_windows = kRippleKeCalS / dt_s;
  const uint8_t n_cal = static_cast<uint8_t>(cal_windows < 1.5f ? 1.0f : (cal_windows > 100.0f ? 100.0f : cal_windows + 0.5f));
  if (r->n_cal < n_cal) {
    r->ke_sum += (v - vb - i * p.ra_ohm) / (w * sat);
    if (++r->n_cal == n_cal) {
      r->ke_cal = r->ke_sum / static_cast<float>(n_cal);
      r->ra_ohm = p.ra_ohm;
      r->tw_C = p.t_ref_C;
      r->have = true;
    }
    return r->have;
  }
  const float a = hpddo::kMaterialThermalRa;
  const float ke = r->ke_cal * sat;
  float ra;
  if (p.ke_tc_per_K != 0.0f) {
    const float den = i * p.ra_ohm * a + ke * w * p.ke_tc_per_K;
    if (!(den > kRippleMinDen || den < -kRippleMinDen)) return r->have;
    ra = p.ra_ohm * (1.0f + a * ((v - vb - ke * w - i * p.ra_ohm) / den));
  } else {
    ra = (v - vb - ke * w) / i;
  }
  const float dev = ra - r->ra_ohm;
  if (dev > kRippleRaGate * r->ra_ohm || dev < -kRippleRaGate * r->ra_ohm) return true;
  r->ra_ohm += dev * (dt_s / (kRippleRaTauS + dt_s));
  r->tw_C = p.t_ref_C + (r->ra_ohm / p.ra_ohm - 1.0f) / a;
  return true;
}

/// Whether a counted frequency is the prior's line: within kRippleCountPriorTol of it.
inline bool ripple_count_confident(float f_hz, float f_prior_hz) {
  if (!(f_prior_hz > 0.0f)) return false;
  const float q = f_hz / f_prior_hz - 1.0f;
  return q <= kRippleCountPriorTol && q >= -kRippleCountPriorTol;
}

}  // namespace acq

#endif  // HPDDO_ACQ_RIPPLE_COUNT_H
