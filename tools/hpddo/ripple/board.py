"""The board's ripple counter (uno_acq/acq_ripple_count.h, issue 23 item 5), the same integer
arithmetic in Python: the reference the simavr test holds the AVR build to, code for code
and count for count (test/firmware/check_uno_ripple.py --count), and the host's replay of
what the board would estimate over a whole run (`ra_track`).

Per burst: a band of two low-pass poles and one high-pass pole (which takes out the mean) whose
shift k follows the back-EMF prior, a rising zero-crossing count with hysteresis at half
the mean |y|; the frequency is (rises - 1) cycles from the first to the last rising crossing.
Per window (`track`): the counts of the span since the last load or voltage step (the
window's current against the span's mean current). Where that frequency lies within PRIOR_TOL
of the span's mean prior, the window is confident and
Ra = (V - brush drop - Ke w) / I is taken, filtered, and turned into the winding temperature
with copper's coefficient (hpddo.schema's thermal_ra material constant).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import bench, schema

# The counter's constants, declared here once: the board's uno_acq/ripple_count_gen.h is
# generated from them (BOARD_CONSTANTS; `cd tools && python -m hpddo.regenerate --write`).
AMP_SHIFT = 8             # the mean |y|'s pole, a shift (256 filtered codes)
LP_MIN, LP_MAX = 2, 10    # the band's low-pass shift k: corners at fs/(2 pi 4) .. fs/(2 pi 1024)
LP_RESET = 5              # k of a burst without a prior's band
PRIOR_TOL = 0.25          # |f / f_prior - 1| at most for a confident count
BAND_LEAD_CYCLES = 320000  # CPU cycles: the main loop's work on a window ends this long after its close at most
COUNT_TAU_S = 0.25        # s: the count's memory, keep = 1 - dt / tau per window older
MIN_CYCLES = 5.0          # weighted ripple cycles at least for a confident speed
STEADY_TOL = 0.03         # a steady operating point: Ra |I - I_span| <= STEADY_TOL Ke w_span
SETTLE_WINDOWS = 2        # windows: a step's and the next, whose counts a new span leaves out
FLOOR_A = 0.10            # A: no Ra below this mean current (the host's floor)
KE_CAL_S = 1.0            # s: confident windows over this long calibrate Ke, cold
RA_TAU_S = 10.0           # s: the Ra filter's time constant
MIN_DEN = 1.0e-3          # V/K: below, the temperature is not observable
RA_GATE = 0.08            # an Ra this far from the filtered one (relative) is a glitch of V or I
T1_SHIFT = 2              # the one-period intervals' running mean: t1 += (iv - t1) >> shift

#: (Python name, the board's name, C type, unit, meaning) of each constant the board takes
BOARD_CONSTANTS = (
    ("AMP_SHIFT", "kRippleAmpShift", "uint8_t", "bits", "the mean |y|'s pole: a += |y| - a >> shift"),
    ("LP_MIN", "kRippleLpMin", "uint8_t", "bits", "k range: band corners at fs/(2 pi 4) .. fs/(2 pi 1024)"),
    ("LP_MAX", "kRippleLpMax", "uint8_t", "bits", "the band's largest low-pass shift"),
    ("LP_RESET", "kRippleLpReset", "uint8_t", "bits", "k of a burst without a prior's band (ripple_counter_reset's)"),
    ("PRIOR_TOL", "kRippleCountPriorTol", "float", "ratio", "|f / f_prior - 1| at most for a confident count"),
    ("BAND_LEAD_CYCLES", "kRippleBandLeadCycles", "uint32_t", "CPU cycles",
     "the main loop's work on a window ends this long after its close at most (with margin)"),
    ("COUNT_TAU_S", "kRippleCountTauS", "float", "s",
     "the count's memory: each older window weighted by 1 - dt / tau (none for windows of tau or longer)"),
    ("MIN_CYCLES", "kRippleMinCycles", "float", "cycles", "weighted ripple cycles at least for a confident speed"),
    ("STEADY_TOL", "kRippleSteadyTol", "float", "1",
     "a steady operating point: Ra |I - I_span| <= tol Ke w_span, the speed's move at constant voltage"),
    ("SETTLE_WINDOWS", "kRippleSettleWindows", "uint8_t", "windows",
     "after a step, the windows whose counts the new span leaves out (the step's and the next)"),
    ("FLOOR_A", "kRippleFloorA", "float", "A", "no Ra below this mean current (the host's floor)"),
    ("KE_CAL_S", "kRippleKeCalS", "float", "s", "confident windows over this long calibrate Ke, cold"),
    ("RA_GATE", "kRippleRaGate", "float", "ratio", "an Ra this far from the filtered one is a glitch of V or I"),
    ("RA_TAU_S", "kRippleRaTauS", "float", "s", "time constant of the Ra filter"),
    ("MIN_DEN", "kRippleMinDen", "float", "V/K", "below, the winding temperature is not observable"),
    ("T1_SHIFT", "kRippleT1Shift", "uint8_t", "bits",
     "the one-period intervals' running mean, which classes a two-period one: t1 += (iv - t1) >> shift"),
)


def _c_literal(value, c_type: str) -> str:
    if c_type == "float":
        return repr(float(value)) + "f"
    return str(int(value)) + ("u" if c_type == "uint32_t" else "")


def header_body() -> str:
    """The text of uno_acq/ripple_count_gen.h below its banner: BOARD_CONSTANTS in namespace acq."""
    values = globals()
    lines = ["#ifndef HPDDO_RIPPLE_COUNT_GEN_H", "#define HPDDO_RIPPLE_COUNT_GEN_H", "", "#include <stdint.h>", "",
             "namespace acq {", ""]
    for name, c_name, c_type, unit, meaning in BOARD_CONSTANTS:
        lines.append(f"/// {meaning} ({unit}; ripple/board.py {name})")
        lines.append(f"static const {c_type} {c_name} = {_c_literal(values[name], c_type)};")
    lines += ["", "}  // namespace acq", "", "#endif  // HPDDO_RIPPLE_COUNT_GEN_H", ""]
    return "\n".join(lines)


#: copper's temperature coefficient of resistance, 1/K (declared once, in the schema)
ALPHA_CU = next(e.material for e in schema.EFFECTS if e.name == "thermal_ra")


@dataclasses.dataclass
class Counter:
    l1: int = 0
    l2: int = 0
    b: int = 0
    amp: int = 0
    k: int = LP_RESET
    high: int = 0
    odd: int = 0
    have_last: int = 0
    settle: int = 0
    t: int = 0
    last_t: int = 0
    t15: int = 0
    t25: int = 0
    cyc: int = 0
    span: int = 0
    t1: int = 0  # running mean of the one-period intervals, PWM periods (0: none since the settling)

    def begin(self, k: int, t_exp: int, gap: int, first_burst: bool, burst_n: int = 0) -> None:
        """acq_ripple_count.h ripple_counter_begin (burst_n: the burst's codes)."""
        self.k, self.odd = k, 0
        self.t = (self.t + gap) & 0xFFFF
        self.t15, self.t25 = min(65535, 3 * t_exp // 2), min(65535, 5 * t_exp // 2)
        if first_burst or gap > self.t25:
            self.settle = min(60000, (8 if first_burst else 4) << (k + 2))
            self.t1 = 0
        elif gap and burst_n >= int(MIN_CYCLES) * t_exp:  # a burst counted alone: its high-pass settles first
            self.settle = 1 << (k + 2)

    def run(self, codes) -> None:
        """ripple_counter_sample on each code, in order (the C++'s 32-bit states never
        overflow: h < 2^18, |y| < 2^18, amp < 2^27; the 16-bit clock wraps as there)."""
        l1, l2, b, amp, k, high, odd = self.l1, self.l2, self.b, self.amp, self.k, self.high, self.odd
        settle, t, last_t, have_last = self.settle, self.t, self.last_t, self.have_last
        t15, t25, cyc, span, t1 = self.t15, self.t25, self.cyc, self.span, self.t1
        for x in codes:
            t = (t + 1) & 0xFFFF
            odd ^= 1
            if not odd:
                continue
            h = int(x) << 8
            l1 += (h - l1) >> k
            l2 += (l1 - l2) >> k
            b += (l2 - b) >> (k + 2)
            y = l2 - b
            amp += abs(y) - (amp >> AMP_SHIFT)
            y9 = y * 512
            if not high:
                if y9 > amp:
                    high = 1
                    if not settle:
                        if have_last:
                            iv = (t - last_t) & 0xFFFF
                            if iv <= t15:
                                cyc, span = cyc + 1, (span + iv) & 0xFFFF
                                d = ((iv - t1 + 0x8000) & 0xFFFF) - 0x8000  # int16 as on the board
                                t1 = (t1 + (d >> T1_SHIFT)) & 0xFFFF if t1 else iv
                            elif iv <= t25 and (not t1 or abs((iv >> 1) - t1) <= t1 >> 2):
                                cyc, span = cyc + 2, (span + iv) & 0xFFFF
                        last_t, have_last = t, 1
            elif y9 < -amp:
                high = 0
            if settle:
                settle -= 1
        self.l1, self.l2, self.b, self.amp, self.high, self.odd = l1, l2, b, amp, high, odd
        self.settle, self.t, self.last_t, self.have_last, self.cyc, self.span = settle, t, last_t, have_last, cyc, span
        self.t1 = t1

    def latch(self) -> tuple:
        """The count since the last latch (the board's at a burst's last code), zeroed."""
        out = (self.cyc, self.span)
        self.cyc = self.span = 0
        return out


def lp_shift(f_hz: float, fs_hz: float) -> int:
    """acq_ripple_count.h ripple_lp_shift (float32 as on the board)."""
    if not f_hz > 0:
        return LP_RESET
    f32 = np.float32
    ratio = f32(fs_hz) / (f32(6.2831853) * f32(2.0) * f32(f_hz))
    k = LP_MIN
    while k < LP_MAX and f32(1 << (k + 1)) <= ratio * f32(1.41421356):
        k += 1
    return k


def counter_hz(cyc: float, span: float, fs_hz: float) -> float:
    """acq_ripple_count.h ripple_counter_hz: NaN without a counted cycle."""
    if not (cyc >= 1) or not (span > 0):
        return math.nan
    return cyc * fs_hz / span


def band_lag(burst_period: int, fs_hz: float) -> int:
    """acq_ripple_count.h ripple_band_lag: windows from the one whose prior sets a burst's band
    to the burst's; 1 when the burst opens at least BAND_LEAD_CYCLES after its window's start
    (2 and 10 Hz windows), else 2 (100 Hz: the board's main loop may still work on the window
    before when the burst opens)."""
    period_cycles = round(bench.HARDWARE.cpu_hz / fs_hz)
    return 1 if burst_period * period_cycles >= BAND_LEAD_CYCLES else 2


RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


def confident(f_hz: float, f_prior_hz: float) -> bool:
    """acq_ripple_count.h ripple_count_confident (float32 as there)."""
    if not f_prior_hz > 0:
        return False
    q = np.float32(f_hz) / np.float32(f_prior_hz) - np.float32(1)
    return bool(-np.float32(PRIOR_TOL) <= q <= np.float32(PRIOR_TOL))


class RaTracker:
    """acq_ripple_count.h RippleRa and ripple_ra_step (float64: the board's float32 differs in
    the last bits). p: the model's PhysicsParams (hpddo.model.physics). ke_fixed: a Ke (V s/rad)
    put in place of the calibrated one once the calibration ends (the host's error budget,
    studies.ripple_board; the board has none)."""

    def __init__(self, p, ke_fixed: float | None = None):
        from ..model import physics
        self.p, self.physics, self.ke_fixed = p, physics, ke_fixed
        self.ke_sum, self.ke_cal, self.ra_ohm, self.tw_C, self.n_cal, self.have = 0.0, 0.0, 0.0, 0.0, 0, False
        self.n_glitch = 0  # windows left out as a glitch (the host's count only: the board keeps none)

    def step(self, v_V: float, i_A: float, rpm: float, dt_s: float) -> bool:
        p, ph = self.p, self.physics
        v = float(ph.true_voltage_V(p, v_V))
        i = float(ph.true_current_A(p, i_A))
        if not (i >= FLOOR_A) or not (rpm > 0):
            return self.have
        w = rpm / RPM_PER_RAD_S
        vb = float(ph.brush_drop_V(p, i))
        sat = float(ph.ke_at_vs_per_rad(p, p.t_ref_C, i)) / p.ke_vs_per_rad
        cal = KE_CAL_S / dt_s
        n_cal = 1 if cal < 1.5 else (100 if cal > 100 else int(cal + 0.5))
        if self.n_cal < n_cal:
            self.ke_sum += (v - vb - i * p.ra_ohm) / (w * sat)
            self.n_cal += 1
            if self.n_cal == n_cal:
                self.ke_cal = self.ke_sum / n_cal if self.ke_fixed is None else self.ke_fixed
                self.ra_ohm, self.tw_C, self.have = p.ra_ohm, p.t_ref_C, True
            return self.have
        ke = self.ke_cal * sat
        if p.ke_tc_per_K != 0:
            den = i * p.ra_ohm * ALPHA_CU + ke * w * p.ke_tc_per_K
            if not abs(den) > MIN_DEN:
                return self.have
            ra = p.ra_ohm * (1.0 + ALPHA_CU * ((v - vb - ke * w - i * p.ra_ohm) / den))
        else:
            ra = (v - vb - ke * w) / i
        if abs(ra - self.ra_ohm) > RA_GATE * self.ra_ohm:  # a glitch of V or I, not the copper
            self.n_glitch += 1
            return True
        self.ra_ohm += (ra - self.ra_ohm) * (dt_s / (RA_TAU_S + dt_s))
        self.tw_C = p.t_ref_C + (self.ra_ohm / p.ra_ohm - 1.0) / ALPHA_CU
        return True


def track(bursts, v_V, i_A, rpm_prior, dt_s: float, p, fs_hz: float, ripples_per_output_rev: float,
          gap_periods: int, ra: RaTracker | None = None):
    """What the board computes over a recording (acq_ripple_board.h on_window, the counter reset
    at the first window): bursts are the windows' current codes in order (each the window's
    last periods, gap_periods after the previous burst's end), v_V, i_A their means, rpm_prior
    the observer's estimates (the back-EMF prior). One dict a window: rpm (NaN without a
    count), confident, have_ra, ra_ohm, tw_C, k, cyc (the burst's own cycles), steady (False
    where the window's current left the span's operating point and the span began again).
    Burst n is counted in the band of window n - band_lag (band_lag(gap_periods, fs_hz)), the
    reset's before that.

    The span (on_window): the counts, currents and priors of the windows since the last load
    or voltage step, each older window's weighted by keep = 1 - dt / COUNT_TAU_S (none for
    windows of COUNT_TAU_S or longer). A window whose current (the mean of its own and the
    window before's: a short window's mean current aliases the ripple, from one window to the
    next in opposite sense) moves from the span's mean by more than a steady operating point
    allows, Ra |dI| > STEADY_TOL Ke w (the speed would move by STEADY_TOL at constant voltage),
    begins a new span (keep 0: its current and prior are the span's first; the window before
    the recording's first has current 0, so the second window begins the span again); its
    count and the next window's are not taken (SETTLE_WINDOWS: the speed and the band settle). A burst holding MIN_CYCLES itself is the count alone. Confident:
    MIN_CYCLES weighted cycles at least, within PRIOR_TOL of the span's mean prior. The band
    of a later burst follows the count where it is confident, else the span's mean prior (one
    100 Hz window's prior is 15-25 % off with its voltage's PWM noise: enough to count a gap of
    two ripple periods as one). Float32 as on the board, operation for operation."""
    f32 = np.float32
    c = Counter()
    ra = RaTracker(p) if ra is None else ra  # a caller's tracker, to read its state afterwards
    lag = band_lag(gap_periods, fs_hz)
    bands = {}  # burst index -> (k, t_exp) from the prior band_lag windows before
    zero = f32(0)
    cyc_w = span_w = n_w = i_w = rpm_w = i_last = zero
    age = SETTLE_WINDOWS
    keep_dt = f32(1) - f32(dt_s) / f32(COUNT_TAU_S) if dt_s < COUNT_TAU_S else zero
    steady_k = f32(2 * STEADY_TOL) / f32(RPM_PER_RAD_S) * f32(p.ke_vs_per_rad)  # V per RPM, the current twice
    ra_ohm = f32(p.ra_ohm)
    fs, per_rev, sixty = f32(fs_hz), f32(ripples_per_output_rev), f32(60)
    out = []
    for n, codes in enumerate(bursts):
        k, t_exp = bands.pop(n, (LP_RESET, 0))
        c.begin(k, t_exp, gap_periods, n == 0, len(codes))
        c.run(codes)
        cyc, span = c.latch()
        own = cyc
        i_n = f32(i_A[n])
        i2 = i_last + i_n  # twice the mean of this window's current and the one before's
        i_last = i_n
        keep, steady = keep_dt, True
        if keep > zero and abs(ra_ohm * (i2 * n_w - i_w)) > steady_k * rpm_w:
            keep, age, steady = zero, 0, False  # a step: the span begins again here
        elif age < SETTLE_WINDOWS:
            age += 1
        keep_cyc = keep
        if age < SETTLE_WINDOWS:
            cyc, span = 0, 0
        elif cyc >= MIN_CYCLES:
            keep_cyc = zero
        cyc_w = cyc_w * keep_cyc + f32(cyc)
        span_w = span_w * keep_cyc + f32(span)
        n_w = n_w * keep + f32(1)
        i_w = i_w * keep + i2
        rpm_w = rpm_w * keep + (f32(rpm_prior[n]) if rpm_prior[n] > 0 else zero)  # as the board: no NaN
        f = cyc_w * fs / span_w if cyc_w >= f32(1) and span_w > zero else f32(math.nan)
        rpm = float(f * sixty / per_rev)
        f_prior = rpm_w * (per_rev / sixty) / n_w  # the span's mean prior, Hz
        f_prior = float(f_prior) if f_prior > zero else 0.0
        conf = bool(f == f and cyc_w >= f32(MIN_CYCLES) and confident(f, f_prior))
        have = ra.step(v_V[n], i_A[n], rpm, dt_s) if conf else ra.have
        out.append(dict(rpm=rpm, confident=conf, have_ra=have, ra_ohm=ra.ra_ohm, tw_C=ra.tw_C, k=c.k, cyc=own,
                        steady=steady))
        f_band = float(f) if conf else f_prior
        bands[n + lag] = (lp_shift(f_band, 0.5 * fs_hz),
                          min(65535, int(f32(fs_hz) / f32(f_band) + f32(0.5))) if f_band > 0 else 0)
    return out
