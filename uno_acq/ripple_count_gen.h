// GENERATED ripple counter constants: DO NOT EDIT. Regenerate with the command below.
// command: cd tools && ../.venv/bin/python -m hpddo.regenerate --write
// source: tools/hpddo/ripple/board.py
// generator: hpddo.schema 1
// checksum: crc32 0xbdedf1ed of the text below this banner
#ifndef HPDDO_RIPPLE_COUNT_GEN_H
#define HPDDO_RIPPLE_COUNT_GEN_H

#include <stdint.h>

namespace acq {

/// the mean |y|'s pole: a += |y| - a >> shift (bits; ripple/board.py AMP_SHIFT)
static const uint8_t kRippleAmpShift = 8;
/// k range: band corners at fs/(2 pi 4) .. fs/(2 pi 1024) (bits; ripple/board.py LP_MIN)
static const uint8_t kRippleLpMin = 2;
/// the band's largest low-pass shift (bits; ripple/board.py LP_MAX)
static const uint8_t kRippleLpMax = 10;
/// k of a burst without a prior's band (ripple_counter_reset's) (bits; ripple/board.py LP_RESET)
static const uint8_t kRippleLpReset = 5;
/// |f / f_prior - 1| at most for a confident count (ratio; ripple/board.py PRIOR_TOL)
static const float kRippleCountPriorTol = 0.25f;
/// the main loop's work on a window ends this long after its close at most (with margin) (CPU cycles; ripple/board.py BAND_LEAD_CYCLES)
static const uint32_t kRippleBandLeadCycles = 320000u;
/// the count's memory: each older window weighted by 1 - dt / tau (none for windows of tau or longer) (s; ripple/board.py COUNT_TAU_S)
static const float kRippleCountTauS = 0.25f;
/// weighted ripple cycles at least for a confident speed (cycles; ripple/board.py MIN_CYCLES)
static const float kRippleMinCycles = 5.0f;
/// a steady operating point: Ra |I - I_span| <= tol Ke w_span, the speed's move at constant voltage (1; ripple/board.py STEADY_TOL)
static const float kRippleSteadyTol = 0.03f;
/// after a step, the windows whose counts the new span leaves out (the step's and the next) (windows; ripple/board.py SETTLE_WINDOWS)
static const uint8_t kRippleSettleWindows = 2;
/// no Ra below this mean current (the host's floor) (A; ripple/board.py FLOOR_A)
static const float kRippleFloorA = 0.1f;
/// confident windows over this long calibrate Ke, cold (s; ripple/board.py KE_CAL_S)
static const float kRippleKeCalS = 1.0f;
/// an Ra this far from the filtered one is a glitch of V or I (ratio; ripple/board.py RA_GATE)
static const float kRippleRaGate = 0.08f;
/// time constant of the Ra filter (s; ripple/board.py RA_TAU_S)
static const float kRippleRaTauS = 10.0f;
/// below, the winding temperature is not observable (V/K; ripple/board.py MIN_DEN)
static const float kRippleMinDen = 0.001f;
/// the one-period intervals' running mean, which classes a two-period one: t1 += (iv - t1) >> shift (bits; ripple/board.py T1_SHIFT)
static const uint8_t kRippleT1Shift = 2;

}  // namespace acq

#endif  // HPDDO_RIPPLE_COUNT_GEN_H
