"""Speed from the commutation ripple (issue 23, docs/ripple-counting.md, "Speed from the ripple"):
per window of a bench log, the output-shaft speed counted from the ripple of the armature current
in its burst (hpddo.logs.ripple), with a confidence, and a reason where there is no confident speed.

The steps, per window:

1. no estimate while the drive is off (duty 0: coasting, no current to ripple) or while the
   mean current is under its floor (the ripple drowns in the ADC's steps);
2. the line: a comb search over the spectrum of the window, each candidate ripple frequency f
   scored by the power at f and at its sub-harmonic family f/2, f/3, f/6 (rotor asymmetry),
   weighted by the back-EMF (M2) prior around N G n_M2 / 60, whose spread is what the prior
   cannot know at that operating point (m2_prior_sd_rpm: a brush drop and Ra's error times I,
   over Ke, beside Ke's own relative error): strong at high speed, weak at low speed and
   high current, where the choice among the family rests on the lines' own evidence;
   a line more than max_prior_z of those sd from the prior is not the ripple (`far`);
   the data's own best candidates among f x {2, 3, 3/2, 1/2, 1/3, 2/3} are checked: where
   one of them fits the data as well and the prior cannot tell them apart, the ambiguity is
   unresolved and said so; before the prior, the line's identity from the data
   (ripple_comb): where the window's lines form a comb of the rotation frequency, the
   commutation line is its strongest, and must sit at ripples_per_rev times it (else
   `multiple`, the number the data show said); a damaged commutator (the line at twice the
   rotation frequency too strong) is `damaged`; every other line inside the prior's spread as
   strong as half the chosen one is a `rival`, compared by power alone, so a moving prior
   cannot make it confident;
3. counting: the current band-passed around f (scipy.signal, Butterworth, zero phase; with
   the neighbouring bursts as margins where they are contiguous), its analytic signal's
   phase unwrapped, the cycles counted over the window (phase advance / 2 pi): the mean
   speed over the window, as the encoder counts it, where one FFT peak would give the
   dominant (final) frequency of a window in which the shaft spins up;
4. the speed's spread over the window's quarters says whether the speed changed inside it
   (inrush, spin-up, a load step), counted, and from the current (at constant duty a change of
   the quarters' mean current is a change of the back-EMF, Ra dI / Ke, which sees a transient
   whose line lay outside the band); then the line has left the fixed band, and the count
   follows it instead (`_tracked_phase`: the line tracked through 50 ms spectra, the current
   demodulated along the track), and is given but not confident.

speed_of_log then counts the windows that failed for want of cycles over spans of steady windows
(count_steady_spans), and names a stall where the drive is on, the current flows and the shaft
stands (count_stalls: no ripple line over a span, a back-EMF prior too low for a count), 0 RPM
with the bound the data give.

Gear ratio and ripples per motor revolution come from the user (`Options`); where an
encoder is there, `check_ratio` measures the ripples per output revolution and says when
the ratio is not the nameplate's.
"""
from __future__ import annotations

import dataclasses
import math
import pathlib

import numpy as np

from . import ripple_sync
from . import ripple_comb as rc

#: the reasons for no confident speed, by key (the texts of `Estimate.reason`)
REASONS = {
    "coasting": "coasting: the drive is off (duty 0), no armature current to ripple",
    "floor": "mean current under the floor",
    "few_cycles": "too few ripple cycles in the window for a count",
    "not_found": "the ripple line not found (no line above the noise near the back-EMF prior)",
    "far": "the strongest line is too far from the back-EMF prior to be the ripple (a fixed line: interference, "
           "while the shaft stands or turns too slowly for its ripple)",
    "ambiguous": "sub-harmonic ambiguity unresolved: another line of the family fits the data as well "
                 "and the back-EMF prior cannot tell them apart",
    "multiple": "the data show another ripples per revolution than the one given",
    "rival": "another line inside the back-EMF prior's spread is as strong, and the data do not place it on the "
             "rotation comb: unresolved",
    "damaged": "a damaged commutator: the lines at once or twice the rotation frequency are too strong against "
               "the commutation line (a worn or burnt bar, a shorted coil, a badly eccentric rotor); the ripple is not "
               "counted through it",
    "changing": "the speed changed inside the window (inrush, spin-up or a load step)",
    "stall": "stall: the drive on and current flowing, but no ripple line over a span of steady windows, and the "
             "back-EMF prior too low for a window's count: the shaft stands (0 RPM within rpm_bound)",
    ripple_sync.KEY: ripple_sync.REASON,
    ripple_sync.KEY_FOLD: ripple_sync.REASON_FOLD,
}
FAMILY = (2, 3, 6)  # the sub-harmonics f/2, f/3, f/6 of rotor asymmetry
ALTERNATIVES = (2.0, 3.0, 1.5, 0.5, 1 / 3, 2 / 3)
# the weight of each sub-harmonic's power in a candidate's evidence: small enough that the main
# line's own second harmonic (2 f, whose f/2 is the main line) does not rival the main line
FAMILY_WEIGHT = 0.25
TRIM = 0.05  # check_ratio: a window's own ripples per encoder revolution this far from the median is left out


@dataclasses.dataclass(frozen=True)
class Options:
    ripples_per_rev: int          # commutation ripples per motor revolution (2 x segments for 2 brushes)
    gear_ratio: float             # motor revolutions per output revolution (the user's figure)
    floor_A: float = 0.10         # no estimate under this mean current
    prior_rel_sd: float = 0.15    # the back-EMF prior's relative uncertainty on a candidate's speed: Ke's error
    #                               (calibration, magnet temperature); beside it the voltages of m2_prior_sd_rpm
    prior_unmodelled_V: float = 0.5   # a voltage the prior (V - I Ra)/Ke does not know: of the order of a brush drop
    prior_ra_rel: float = 0.2     # Ra's relative error in the prior: the multimeter's value against a winding
    #                               up to ~50 K warmer (copper +0.39 %/K) or colder
    min_snr: float = 10.0         # the line's power over the local noise floor
    min_cycles: float = 5.0       # ripple cycles a window must hold
    max_spread: float = 0.03      # relative spread of the quarter-window speeds still counted as steady
    band: float = 1.2             # the band-pass: f / band .. f * band
    ambiguity: float = 0.5        # an alternative with this share of the best's evidence (prior-weighted) is a rival
    max_prior_z: float = 3.0      # a line further than this many of the prior's sd from it is not the ripple
    #                               (a fixed line, interference, while the shaft stands or turns slowly)
    span_max_s: float = 10.0      # count_steady_spans: the longest span of steady windows counted as one (s);
    #                               0 turns the multi-window count off
    standing_V: float = 0.010     # standing(): with the drive off and no current the open terminals show the
    #                               back-EMF; under this |V| the shaft stands (|n| < standing_V / Ke, 0.25 RPM at
    #                               0.38 V s/rad); 0 turns the label off
    settled_tail: bool = False    # count_settled_tails: a `changing` window counted again over its part after the
    #                               step (the tail), its head's speed from the back-EMF; off by default (the
    #                               ripple pages' figures are without it, but docs/ripple-step-windows.md, "Settled
    #                               tails (off by default)", which measures it)
    tail_starts: tuple = (0.1, 0.2, 0.3, 0.4)   # count_settled_tails: where the tail may begin, shares of the window
    tail_min_cycles: float = 10.0  # count_settled_tails: ripple cycles a tail must hold; a tail has no margins, so
    #                               its count leaves a tenth out at each end and reads the phase at filter edges
    #                               (4 % off on a steady tail of 5.2 cycles, unseen x0.25 seed 2;
    #                               docs/ripple-step-windows.md, "Settled tails (off by default)")
    stall_max_rpm: float = 1.0    # count_stalls: the largest bound on |n| (RPM, output shaft) the data must give
    #                               for a stall (the drive on, current above the floor, the shaft standing);
    #                               0 turns the stall off
    stall_cycles: float = 3.0     # count_stalls: the ripple cycles a line is taken to need over a span to stand
    #                               out in its spectrum (Hann window, trend removed), so a span of S s bounds |n| to
    #                               stall_cycles / (N G S) revolutions per second; a margin: on synthetic bursts 1-2
    #                               cycles stood out too, a real current's slow drifts fill the lowest bins
    stall_snr: float = 30.0       # count_stalls: a bin of the span's spectrum this many times the band's median
    #                               power is a line; noise alone (exponential power per bin, median ln 2 of the
    #                               mean) reaches it with probability 2^-30 ~ 1e-9 a bin, a ripple of 1.5 mA at 3
    #                               cycles over 9.5 s stood 153x over it at the least (docs/ripple-counting.md,
    #                               "Speed from the ripple", step 6)
    stall_prior_z: float = 1.0    # count_stalls: the back-EMF prior plus this many of its upper sd must lie under
    #                               the speed floor (min_cycles ripples per window)


def m2_prior_rpm(v_V, i_A, ra_ohm: float, ke_vs_per_rad: float):
    """The back-EMF estimate of the output speed, RPM: (V - I Ra) / Ke (M2 without effects)."""
    return (np.asarray(v_V, float) - np.asarray(i_A, float) * ra_ohm) / ke_vs_per_rad * 60.0 / (2 * math.pi)


def m2_prior_sd_rpm(v_V, i_A, ra_ohm: float, ke_vs_per_rad: float, opts: Options):
    """What the back-EMF prior (V - I Ra) / Ke cannot know at each window's operating point, as
    a speed (RPM), below and above it (an array (n, 2)): a voltage the winding does not see.

        below: u / Ke,  u = sqrt(U^2 + (ra_rel Ra I)^2);     above: ra_rel Ra I / Ke

    U (opts.prior_unmodelled_V) is of the order of a brush drop: it only takes voltage from the
    winding, so it only puts the speed below the prior; Ra's error times I (opts.prior_ra_rel)
    goes either way (a winding warmer or colder than when Ra was measured). Beside it the
    likelihood takes Ke's own relative error (opts.prior_rel_sd) times the candidate's speed
    (`_prior_like`). Against the back-EMF E = V - I Ra these voltages are small at high speed
    (a strong prior) and a large share of E at low speed and high current (a weak one)."""
    i = np.abs(np.asarray(i_A, float))
    u_ra = opts.prior_ra_rel * ra_ohm * i
    u = np.hypot(opts.prior_unmodelled_V, u_ra)
    to_rpm = 60.0 / (2 * math.pi) / ke_vs_per_rad
    return np.stack([u * to_rpm, u_ra * to_rpm], axis=-1)


def _prior_like(g, f_prior, sd_below, sd_above, rel_sd):
    """The prior's weight at the candidate frequencies g (Hz) and their distance from it in sd:
    z = (g - f_prior) / sqrt(sd_side^2 + (rel_sd g)^2), a voltage error (sd_below under the prior,
    sd_above over it, in Hz) and Ke's relative error on the candidate's own back-EMF. Ones and
    zeros without a prior."""
    g = np.asarray(g, float)
    if not np.isfinite(f_prior):
        return np.ones_like(g), np.zeros_like(g)
    d = g - f_prior
    z = d / np.sqrt(np.where(d < 0, sd_below, sd_above) ** 2 + (rel_sd * g) ** 2)
    return np.exp(-0.5 * z ** 2), z


def _spectrum(x, fs, pad=8):
    n = len(x)
    t = np.arange(n)
    xd = x - np.polyval(np.polyfit(t, x, 1), t)
    nfft = 1 << int(math.ceil(math.log2(n * pad)))
    a = np.abs(np.fft.rfft(xd * np.hanning(n), nfft)) ** 2
    f = np.fft.rfftfreq(nfft, 1.0 / fs)
    return f, a


def _line(f_grid, p_max, f):
    """Power of the strongest bin within half a resolution of f (p_max: the max-filtered spectrum)."""
    return np.interp(f, f_grid, p_max, left=0.0, right=0.0)


def _window(bursts, k, fs):
    """The burst of window k with its contiguous neighbours as margins (half a window each side):
    (current A, index of the window's first sample, its number of samples)."""
    x = bursts.current_A(k)
    n = len(x)
    parts, start = [x], 0
    if k > 0 and abs(bursts.t_s[k - 1] + len(bursts.codes[k - 1]) / fs - bursts.t_s[k]) < 1.5 / fs:
        prev = bursts.current_A(k - 1)[-(n // 2):]
        parts.insert(0, prev)
        start = len(prev)
    if k + 1 < len(bursts) and abs(bursts.t_s[k] + n / fs - bursts.t_s[k + 1]) < 1.5 / fs:
        parts.append(bursts.current_A(k + 1)[: n // 2])
    return np.concatenate(parts), start, n


def _tracked_phase(x, fs, f_end, i_end, frame_s=0.05):
    """The ripple's phase (rad) over x, following its line as the speed changes: the line's
    frequency tracked backwards from f_end at sample i_end through short spectra (each frame's
    peak within 20 % of the next frame's), integrated to a phase, and refined by demodulating
    x with it (the residual phase of the heterodyned, low-passed signal). None where the frames
    are too short for the line."""
    from scipy import signal

    seg = int(round(frame_s * fs))
    if seg < 16 or f_end * frame_s < 2 or len(x) < 2 * seg:
        return None
    hop = seg // 4
    f, t, Z = signal.stft(x - x.mean(), fs=fs, nperseg=seg, noverlap=seg - hop, boundary=None, padded=False,
                          nfft=8 * seg)
    P = np.abs(Z) ** 2
    j_end = int(np.clip(np.searchsorted(t, i_end / fs) - 1, 0, len(t) - 1))
    track = np.full(len(t), np.nan)
    prev = f_end
    for j in list(range(j_end, -1, -1)) + list(range(j_end + 1, len(t))):
        if j == j_end + 1:
            prev = track[j_end]
        sel = (f >= prev / 1.2) & (f <= prev * 1.2) & (f >= 1.0 / frame_s)
        if sel.any():
            prev = float(f[sel][np.argmax(P[sel, j])])
        track[j] = prev
    f_t = np.interp(np.arange(len(x)) / fs, t, track)
    phi = 2 * math.pi * np.cumsum(f_t) / fs
    z = x * np.exp(-1j * phi)
    sos = signal.butter(3, 0.2 * max(f_end, 1.0 / frame_s), btype="lowpass", fs=fs, output="sos")
    zl = signal.sosfiltfilt(sos, z.real) + 1j * signal.sosfiltfilt(sos, z.imag)
    return phi + np.unwrap(np.angle(zl))


def _current_spread(x0, fs, f_Hz, rpm, rpm_per_A):
    """The speed change inside a window that the back-EMF gives from the current alone: the
    lines of the ripple (f, its second harmonic and the family f/2, f/3, f/6 that the window holds
    a whole cycle of) fitted out by least squares, the mean of what is left over each quarter;
    at the window's constant duty a change of it is a change of the back-EMF, -Ra dI, i.e. of the
    speed, rpm_per_A dI (Ra / Ke in RPM per A): (max - min) over the quarters, relative to rpm.
    It sees a transient that the fixed band cannot (the line outside the band at the window's
    start)."""
    n = len(x0)
    t = np.arange(n) / fs
    cols = [np.ones(n)]  # the mean, fitted with the lines (a line of few cycles does not average out)
    for h in (1.0, 2.0) + tuple(1.0 / d for d in FAMILY):
        if h * f_Hz * n / fs >= 1.0 and h * f_Hz < fs / 2:
            cols += [np.cos(2 * math.pi * h * f_Hz * t), np.sin(2 * math.pi * h * f_Hz * t)]
    a = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(a, x0, rcond=None)
    x = x0 - a[:, 1:] @ coef[1:]
    means = [float(q.mean()) for q in np.array_split(x, 4)]
    return rpm_per_A * (max(means) - min(means)) / max(abs(rpm), 1e-12)


def estimate_window(bursts, k, duty, rpm_prior, opts: Options, prior_before=None, prior_sd=None, rpm_per_A=None):
    """One window: dict with rpm (count), rpm_fft (one FFT peak in the band), f_Hz (the counted
    frequency), f_strongest_Hz (the strongest line of the spectrum, for comparison), cycles, snr, spread,
    confidence (0..1), reason ('' when confident), key (REASONS key or ''). prior_before: the
    previous window's prior (RPM), the speed where this window starts, bounding a tracked count.
    prior_sd: the prior's voltage-borne sd at this window (RPM), one figure or (below, above)
    (m2_prior_sd_rpm); None: 0 (Ke's relative error, opts.prior_rel_sd, alone). rpm_per_A: Ra / Ke
    in RPM per A, the speed change a change of current means at constant duty (_current_spread;
    None: not checked)."""
    from scipy import signal

    fs = bursts.sample_hz
    out = dict(rpm=math.nan, rpm_fft=math.nan, f_Hz=math.nan, f_strongest_Hz=math.nan, cycles=math.nan, snr=math.nan,
               spread=math.nan, spread_current=math.nan, i_mean_A=math.nan, rot_hz=math.nan, multiple=0,
               rot1_rel=math.nan, rot2_rel=math.nan, confidence=0.0, reason="", key="")
    x0 = bursts.current_A(k)
    n = len(x0)
    if n < 16:
        out.update(key="few_cycles", reason=REASONS["few_cycles"])
        return out
    i_mean = float(x0.mean())
    out["i_mean_A"] = i_mean
    if duty is not None and duty == 0.0:
        out.update(key="coasting", reason=REASONS["coasting"])
        return out
    if abs(i_mean) < opts.floor_A and ripple_sync.holds_mean(bursts):
        out.update(key="floor", reason=f"{REASONS['floor']} ({i_mean * 1000:.0f} mA < {opts.floor_A * 1000:.0f} mA)")
        return out
    T = n / fs
    per_rev_out = opts.ripples_per_rev * opts.gear_ratio  # ripples per output revolution

    def rpm_of(f_Hz):
        return f_Hz * 60.0 / per_rev_out

    f_prior = rpm_prior * per_rev_out / 60.0 if rpm_prior is not None and np.isfinite(rpm_prior) else math.nan
    sd_lo, sd_hi = (np.nan_to_num(np.broadcast_to(np.asarray(prior_sd, float), (2,)), nan=0.0) * per_rev_out / 60.0
                    if prior_sd is not None else (0.0, 0.0))

    # 2. the line: comb evidence weighted by the prior
    f, p = _spectrum(x0, fs)
    res = 1.0 / T
    from scipy.ndimage import maximum_filter1d
    step = f[1] - f[0]
    p_max = maximum_filter1d(p, size=max(1, int(round(res / step))) | 1)
    f_lo = max(2.0 * res, 0.5)
    f_hi = fs / 2.0 / 2.2
    grid = np.geomspace(f_lo, f_hi, 4000)

    def evidence(g):
        e = _line(f, p_max, g)
        for d in FAMILY:
            gd = g / d
            e = e + FAMILY_WEIGHT * np.where(gd >= 1.5 * res, _line(f, p_max, gd), 0.0)
        return e

    band_all = (f >= f_lo) & (f <= f_hi)
    out["f_strongest_Hz"] = float(f[band_all][np.argmax(p[band_all])])  # one FFT peak, no prior, no family
    found = rc.lines(f, p, f_lo, f_hi, res, opts.min_snr)
    found = rc.without_fixed(found, bursts, res)
    comb = rc.rotation_comb(found, res, opts.min_snr, rc.fixed_hz_of(bursts))
    if comb is not None:  # the line's identity from the data: the comb of rotation lines
        out.update(rot_hz=comb.rot_hz, multiple=comb.multiple)
        out["rot1_rel"], out["rot2_rel"] = rc.health(f, p_max, comb.rot_hz, comb.commutation.hz, res)
        if rc.damaged(out["rot1_rel"], out["rot2_rel"]):
            out.update(key="damaged", f_Hz=comb.commutation.hz, snr=comb.commutation.snr,
                       reason=rc.damaged_reason(REASONS["damaged"], out["rot1_rel"], out["rot2_rel"], comb.rot_hz))
            return out
        if comb.multiple != opts.ripples_per_rev:
            out.update(key="multiple", f_Hz=comb.commutation.hz, snr=comb.commutation.snr,
                       rpm=comb.rot_hz * 60.0 / opts.gear_ratio,
                       reason=f"{REASONS['multiple']}: the ripple is {comb.multiple} per revolution, not the "
                              f"{opts.ripples_per_rev} given (rotation lines {comb.rot_hz:.2f} Hz apart, the "
                              f"strongest at {comb.multiple} x, {comb.commutation.hz:.1f} Hz)")
            return out
    ev = evidence(grid)
    like, z = _prior_like(grid, f_prior, sd_lo, sd_hi, opts.prior_rel_sd)
    post = ev * like
    j = int(np.argmax(post))
    f_star = float(grid[j]) if comb is None else comb.commutation.hz
    z_star = float(z[j]) if comb is None else float(_prior_like([f_star], f_prior, sd_lo, sd_hi, opts.prior_rel_sd)[1][0])
    # the local noise floor: the median power from f*/2 to 2 f*, lines excluded by the median
    sel = (f > f_star / 2) & (f < 2 * f_star)
    floor = float(np.median(p[sel])) if sel.sum() > 8 else float(np.median(p))
    snr = _line(f, p_max, f_star) / max(floor, 1e-30)
    out["snr"] = float(snr)
    if snr < opts.min_snr or (comb is None and post[j] <= 0):
        out.update(key="not_found", reason=REASONS["not_found"], f_Hz=f_star)
        return out
    if abs(z_star) > opts.max_prior_z:  # a line the back-EMF cannot hold: not the ripple
        out.update(key="far", f_Hz=f_star, reason=f"{REASONS['far']} ({f_star:.1f} Hz, {rpm_of(f_star):.1f} RPM, "
                   f"{z_star:+.1f} sd from the prior's {rpm_prior:.1f} RPM)")
        return out
    fixed = ripple_sync.fixed_line(bursts, k, f_star, res)  # a PWM or mains line, or a refused fold
    if fixed:
        out.update(key=fixed[0], f_Hz=f_star, reason=fixed[1])
        return out
    # rivals: every line inside the prior's spread (max_prior_z of its sd) as strong as opts.ambiguity of the
    # chosen one's power, the comb's own lines but where the comb has placed them (mains and PWM multiples,
    # a neighbouring rotation line where no comb is seen); weighed by their power alone, so that a prior
    # which moves cannot turn one of them into a confident answer
    placed = [ln.hz for ln, _ in comb.lines] if comb is not None else []
    riv = rc.rivals(found, f_star, res, lambda hz: abs(_prior_like([hz], f_prior, sd_lo, sd_hi, opts.prior_rel_sd)[1][0])
                    <= opts.max_prior_z, opts.ambiguity, placed)
    if riv:
        out.update(key="rival", f_Hz=f_star, reason=f"{REASONS['rival']} ({f_star:.1f} Hz or {riv[0].hz:.1f} Hz, "
                   f"{riv[0].power / max(_line(f, p_max, f_star), 1e-300):.2f} of its power)")
        return out
    # rivals in the family where no comb places the line: the data's own evidence at f* x r, weighted by the prior
    alt = ALTERNATIVES
    alt_f = np.array([f_star * r for r in alt])
    ok = (alt_f > f_lo) & (alt_f < f_hi)
    if comb is None and ok.any():
        alt_ev = evidence(alt_f[ok])
        alt_like, _ = _prior_like(alt_f[ok], f_prior, sd_lo, sd_hi, opts.prior_rel_sd)
        rival = float(np.max(alt_ev * alt_like / max(like[j], 1e-300)))
        if rival >= opts.ambiguity * float(ev[j]):
            r = alt_f[ok][int(np.argmax(alt_ev * alt_like))]
            out.update(key="ambiguous", f_Hz=f_star,
                       reason=f"{REASONS['ambiguous']} ({f_star:.1f} Hz or {r:.1f} Hz)")
            return out
    if comb is None:  # the health lines where the user's ripples per revolution put the rotation: reported, but
        # a damaged commutator is named only where the comb shows the rotation (a wrong figure given would put
        # these lines elsewhere)
        out["rot1_rel"], out["rot2_rel"] = rc.health(f, p_max, f_star / opts.ripples_per_rev, f_star, res)

    # 3. counting demodulated cycles
    xx, s0, nw = _window(bursts, k, fs)
    lo, hi = f_star / opts.band, min(f_star * opts.band, 0.45 * fs)
    sos = signal.butter(3, [lo, hi], btype="bandpass", fs=fs, output="sos")
    y = signal.sosfiltfilt(sos, xx - xx.mean())
    phase = np.unwrap(np.angle(signal.hilbert(y)))
    if s0 == 0 and len(xx) == nw:  # no margins: leave the filter's edges out
        b, e = int(0.1 * nw), int(0.9 * nw)
    else:
        b, e = s0, s0 + nw - 1
    cycles = (phase[e] - phase[b]) / (2 * math.pi)
    f_count = cycles / ((e - b) / fs)
    q = np.linspace(b, e, 5).astype(int)
    fq = np.diff(phase[q]) / (2 * math.pi) / (np.diff(q) / fs)
    spread = float((fq.max() - fq.min()) / max(abs(f_count), 1e-12))
    spread_i = (_current_spread(x0, fs, f_count, f_count * 60.0 / per_rev_out, rpm_per_A)
                if rpm_per_A is not None and np.isfinite(rpm_per_A) and f_count > 0 else 0.0)
    out["spread_current"] = spread_i
    if max(spread, spread_i) > opts.max_spread:  # the speed moved out of the fixed band: follow the line instead
        tracked = _tracked_phase(xx, fs, f_star, e)
        if tracked is not None:
            f_tr = (tracked[e] - tracked[b]) / (2 * math.pi) / ((e - b) / fs)
            # the mean of a transition lies between its ends: the speed before the window (the
            # previous window's prior) and the line at its end; a track outside has jumped lines
            f_a = (prior_before * per_rev_out / 60.0 if prior_before is not None and np.isfinite(prior_before)
                   else math.nan)
            if not np.isfinite(f_a) or min(f_a, f_star) / 1.1 <= f_tr <= max(f_a, f_star) * 1.1:
                phase = tracked
                cycles = (phase[e] - phase[b]) / (2 * math.pi)
                f_count = f_tr
                fq = np.diff(phase[q]) / (2 * math.pi) / (np.diff(q) / fs)
                spread = float((fq.max() - fq.min()) / max(abs(f_count), 1e-12))
    k_fft = (f >= lo) & (f <= hi)
    f_fft = float(f[k_fft][np.argmax(p[k_fft])]) if k_fft.any() else math.nan
    out.update(rpm=f_count * 60.0 / per_rev_out, rpm_fft=f_fft * 60.0 / per_rev_out, f_Hz=f_count,
               cycles=f_count * T, spread=spread)
    if f_count * T < opts.min_cycles:
        out.update(key="few_cycles", reason=f"{REASONS['few_cycles']} ({f_count * T:.1f} < {opts.min_cycles:g})")
        return out
    if max(spread, spread_i) > opts.max_spread:
        out.update(key="changing", reason=f"{REASONS['changing']} (quarters spread {spread:.1%}; from the "
                   f"current, Ra dI / Ke, {spread_i:.1%})")
        return out
    fixed = ripple_sync.fixed_line(bursts, k, f_count, res)  # the counted line, too, off the PWM and mains lines
    if fixed:
        out.update(key=fixed[0], reason=fixed[1])
        return out
    out["confidence"] = float(min(1.0, (1 - math.exp(-snr / (4 * opts.min_snr)))
                                  * (1 - max(spread, spread_i) / opts.max_spread / 2)))
    return out


def estimate(bursts, duty, rpm_prior, opts: Options, prior_sd=None, rpm_per_A=None):
    """Every window of a recording (a pandas DataFrame, one row per burst; see estimate_window).
    duty, rpm_prior: per window (None or NaN where unknown); prior_sd: the prior's voltage-borne
    sd per window (RPM), one figure or (below, above) (m2_prior_sd_rpm; None: 0, Ke's relative
    error opts.prior_rel_sd alone). The prior passes a running median of three windows first, so
    that a glitch of one sample of V or I cannot steer the line; where the window's own prior and that median disagree (a step of speed beside a
    glitch, where the median takes the speed before the step), the window's speed may be either,
    and the prior's sd spans both: sd = sqrt(sd^2 + (own - median)^2). The DataFrame carries
    the prior used (`rpm_prior_used`) and its sd (`prior_sd_below`, `prior_sd_above`). rpm_per_A:
    Ra / Ke in RPM per A (rpm_per_amp), for the speed change the current shows inside a window."""
    import pandas as pd

    n = len(bursts)
    sd = np.zeros((n, 2))
    if prior_sd is not None:  # one figure per window, or (below, above)
        given = np.asarray(prior_sd, float)
        given = np.repeat(given[:, None], 2, axis=1) if given.ndim == 1 else given
        sd = np.where(np.isfinite(given), given, 0.0)
    if rpm_prior is not None:  # a one-window glitch of V or I must not move the prior: median of three
        own = np.asarray(rpm_prior, float)
        pr = own
        if len(pr) >= 3:
            pr = np.concatenate([pr[:1], np.median(np.stack([pr[:-2], pr[1:-1], pr[2:]]), axis=0), pr[-1:]])
            gap = np.nan_to_num(np.abs(own - pr), nan=0.0)
            sd = np.hypot(sd, gap[:, None])
        rpm_prior = pr
    rows = []
    for k in range(n):
        d = None if duty is None else float(duty[k])
        pr = None if rpm_prior is None else float(rpm_prior[k])
        before = None if rpm_prior is None or k == 0 else float(rpm_prior[k - 1])
        rows.append(estimate_window(bursts, k, d, pr, opts, before, sd[k], rpm_per_A))
    df = pd.DataFrame(rows)
    df.insert(0, "seq", bursts.seq)
    df["confident"] = df["key"] == ""
    df["rpm_prior_used"] = np.nan if rpm_prior is None else rpm_prior
    df["prior_sd_below"] = sd[:, 0] if rpm_prior is not None else np.nan
    df["prior_sd_above"] = sd[:, 1] if rpm_prior is not None else np.nan
    return df


def count_settled_tails(bursts, duty, est, opts: Options, rpm_per_A=None):
    """A window whose speed changed inside it (`changing`: a step of duty or load, the inrush after
    it) counted again over the part after the step has settled (opts.settled_tail;
    docs/ripple-step-windows.md, "Settled tails (off by default)"). The tail, the burst from
    opts.tail_starts[j] of the window on (the earliest that passes), is counted as its own window (estimate_window) with every check of one:
    the prior, `far`, `ambiguous`, the line above the noise, at least opts.tail_min_cycles cycles in
    the tail, its counted quarters and its current's quarters steady within opts.max_spread. The speed
    of the head (the transient) comes from the back-EMF: at the window's constant duty the speed
    moves by -Ra dI / Ke when the current moves by dI, so over the head the speed lies rpm_per_A x
    (mean current of the head - that of the tail) below the tail's. The window's mean speed, which
    the encoder counts, is then

        n = n_tail - rpm_per_A x (head share) x (I_head - I_tail)

    whose correction carries Ra's and Ke's errors (opts.prior_ra_rel, opts.prior_rel_sd), a share
    of a correction of 0.2-1.4 % at the bench's inertia (unseen x0.25). The row takes that speed,
    the tail's confidence, and `tail_start` (the head's share; NaN elsewhere). Needs rpm_per_A (Ra / Ke, RPM per A); without
    it, or without opts.settled_tail, est is returned as it is (no `tail_start` column). est:
    estimate()'s DataFrame for these bursts, its prior columns included. Returns a copy."""
    if not opts.settled_tail or rpm_per_A is None or not np.isfinite(rpm_per_A):
        return est
    est = est.copy()
    est["tail_start"] = np.nan
    prior = est["rpm_prior_used"].to_numpy(float)
    sd = est[["prior_sd_below", "prior_sd_above"]].to_numpy(float)
    for k in np.flatnonzero(est["key"].to_numpy() == "changing"):
        d = None if duty is None else float(np.asarray(duty, float)[k])
        if not np.isfinite(prior[k]):
            continue
        x = bursts.current_A(k)
        n = len(x)
        for share in opts.tail_starts:
            i0 = int(round(share * n))
            if not 0 < i0 < n:
                continue
            tail = bursts.one(k, np.asarray(bursts.codes[k])[i0:], i0 / bursts.sample_hz)
            r = estimate_window(tail, 0, d, float(prior[k]), opts, None, sd[k], rpm_per_A)
            if r["key"] or not r["cycles"] >= opts.tail_min_cycles:
                continue
            head = i0 / n
            rpm = r["rpm"] - rpm_per_A * head * (float(x[:i0].mean()) - float(x[i0:].mean()))
            per_rev_out = opts.ripples_per_rev * opts.gear_ratio
            est.loc[est.index[k], ["rpm", "f_Hz", "cycles", "snr", "spread", "spread_current", "confidence"]] = [
                rpm, rpm * per_rev_out / 60.0, r["cycles"], r["snr"], r["spread"], r["spread_current"],
                r["confidence"]]
            est.loc[est.index[k], ["key", "reason"]] = ""
            est.loc[est.index[k], "confident"] = True
            est.loc[est.index[k], "tail_start"] = head
            break
    return est


#: the single-window reasons that a count over several steady windows may lift: the window held too few
#: cycles or too little evidence for its line; not `changing` (the speed moved), `far`, `floor`, `coasting`
SPAN_KEYS = ("few_cycles", "not_found", "ambiguous", "rival")


def _contiguous(bursts, k) -> bool:
    """Whether burst k + 1 starts where burst k ends (one sample period apart at most)."""
    fs = bursts.sample_hz
    return abs(bursts.t_s[k] + len(bursts.codes[k]) / fs - bursts.t_s[k + 1]) < 1.5 / fs


def steady_spans(bursts, duty, keys, opts: Options, span_keys=SPAN_KEYS) -> list:
    """The spans (first, end) of consecutive windows that count_steady_spans counts as one: runs of
    windows at the same nonzero duty whose own count failed for a reason in span_keys (SPAN_KEYS;
    count_stalls: STALL_KEYS), each burst
    contiguous with the next (so the current is one record over the span), not the first window
    after a change of duty (the inrush); a run longer than opts.span_max_s is cut into equal spans
    no longer than it, each of two windows at least. A run of one window is no span."""
    n = len(bursts)
    if opts.span_max_s <= 0 or n < 2 or duty is None:
        return []
    duty = np.asarray(duty, float)
    lengths = np.array([len(c) for c in bursts.codes]) / bursts.sample_hz
    ok = np.array([keys[k] in span_keys and np.isfinite(duty[k]) and duty[k] > 0
                   and (k > 0 and duty[k - 1] == duty[k]) for k in range(n)])
    spans, k = [], 0
    while k < n:
        if not ok[k]:
            k += 1
            continue
        e = k + 1
        while e < n and ok[e] and duty[e] == duty[k] and _contiguous(bursts, e - 1):
            e += 1
        if e - k >= 2:
            n_cut = min(int(math.ceil(float(lengths[k:e].sum()) / opts.span_max_s - 1e-9)), (e - k) // 2)
            cuts = np.linspace(k, e, max(n_cut, 1) + 1).round().astype(int)
            spans += [(int(a), int(b)) for a, b in zip(cuts[:-1], cuts[1:]) if b - a >= 2]
        k = e
    return spans


def count_steady_spans(bursts, duty, est, opts: Options, rpm_per_A=None):
    """The ripple counted over several consecutive windows where one window holds too few cycles or
    too little evidence (a slow shaft: at duty 0.2 the bench turns at 4-6 RPM, about one ripple
    cycle in a 0.5 s window). Over a span of steady windows (steady_spans: the same duty, the bursts
    contiguous) the speed is constant, so the bursts are one record of the current, counted as one
    window (estimate_window) with every honesty check of a single one: the prior (the median of the
    span's priors and of their sd, the window before the span as the speed before it), `far`,
    `ambiguous`, the line above the noise, at least opts.min_cycles cycles over the span, and the
    steadiness across the span (the counted quarters and the current's quarters, Ra dI / Ke, within
    opts.max_spread). Where the span's count is confident, each of its windows takes its speed and
    confidence (`span`: the number of windows counted together); elsewhere each window keeps its
    own estimate and reason. est: estimate()'s DataFrame for these bursts. Returns a copy."""
    est = est.copy()
    est["span"] = 1
    est["span_first"] = np.arange(len(est))  # the first window of the row's span (its own where no span)
    keys = est["key"].to_numpy()
    prior = est["rpm_prior_used"].to_numpy(float)
    sd = est[["prior_sd_below", "prior_sd_above"]].to_numpy(float)
    for a, e in steady_spans(bursts, duty, keys, opts):
        joined = bursts.one(a, np.concatenate(bursts.codes[a:e]))
        has_prior = bool(np.isfinite(prior[a:e]).any())
        pr = float(np.nanmedian(prior[a:e])) if has_prior else None
        psd = np.nanmedian(sd[a:e], axis=0) if has_prior else None
        before = float(prior[a - 1]) if has_prior and a > 0 and np.isfinite(prior[a - 1]) else None
        r = estimate_window(joined, 0, float(np.asarray(duty, float)[a]), pr, opts, before, psd, rpm_per_A)
        if r["key"]:
            continue
        idx = est.index[a:e]
        for c in ("rpm", "rpm_fft", "f_Hz", "f_strongest_Hz", "snr", "spread", "spread_current", "confidence"):
            est.loc[idx, c] = r[c]
        est.loc[idx, "cycles"] = r["cycles"] / (e - a)  # the window's share of the span's cycles
        est.loc[idx, ["key", "reason"]] = ""
        est.loc[idx, "confident"] = True
        est.loc[idx, "span"] = e - a
        est.loc[idx, "span_first"] = a
    return est


#: the reasons after the spans under which a shaft may stand: no line, too few cycles, a rival line, or a
#: fixed line far from the prior (interference while the shaft stands)
STALL_KEYS = ("few_cycles", "not_found", "ambiguous", "rival", "far")


def _upper_speed(prior_rpm: float, sd_above_rpm: float, rel_sd: float, z: float) -> float:
    """The speed n above the prior p that lies z of the prior's sd from it, where that sd grows with
    n as in _prior_like: (n - p)^2 = z^2 (sd_above^2 + (rel_sd n)^2), the larger root; inf where
    Ke's relative error alone lets every speed within z sd (z rel_sd >= 1)."""
    a = 1.0 - (z * rel_sd) ** 2
    if a <= 0:
        return math.inf
    p = prior_rpm
    disc = p * p - a * (p * p - (z * sd_above_rpm) ** 2)
    return (p + math.sqrt(max(disc, 0.0))) / a


def speed_floor_rpm(window_s: float, opts: Options) -> float:
    """The output speed at which window_s seconds of current hold opts.min_cycles ripples, RPM:
    under it a window's own count cannot be confident (22.7 RPM for 0.5 s windows and 26.4
    ripples per output revolution)."""
    return opts.min_cycles / window_s / (opts.ripples_per_rev * opts.gear_ratio) * 60.0


def count_stalls(bursts, duty, est, opts: Options, rpm_per_A=None):
    """A stall where the data determine it: the drive on, the current above the floor, and the
    shaft standing (a jammed pump or gear). A standing rotor commutates nothing, so there is no
    ripple to count; these windows fail their count (STALL_KEYS) one at a time and over a span.
    Over each span of steady windows (steady_spans with STALL_KEYS: the same nonzero duty, bursts
    contiguous, not the first window after a change of duty), two facts of physics, both required:

    1. the back-EMF prior cannot turn the shaft fast enough for a window's count: the span's
       prior (the median of its windows' priors) plus opts.stall_prior_z of its upper sd
       (sqrt(sd_above^2 + (prior_rel_sd n)^2), m2_prior_sd_rpm) lies under the speed floor
       (speed_floor_rpm of the span's median burst);
    2. the span's current holds no ripple line: in its spectrum (trend removed, Hann window) the
       strongest bin from stall_cycles / S (S the span's length, s) to the ripple frequency of the
       highest speed the prior allows (max_prior_z sd above it, at least the speed floor) is under
       opts.stall_snr times the band's median power. A shaft turning at n makes a line at
       N G n / 60 Hz with N G n S / 60 cycles over the span; one of stall_cycles or more would
       stand out, so the span's mean speed is |n| < 60 stall_cycles / (N G S).

    A window's own speed may differ from the span's mean; at the span's constant duty a change
    of the speed is a change of the back-EMF, -Ra dI, so the windows' mean currents bound it:
    the bound adds rpm_per_A x (max - min of the windows' mean currents). A span is a stall
    where that bound (`rpm_bound`, RPM) is at most opts.stall_max_rpm: each of its windows takes
    rpm 0, `stall` True, key "stall", the bound, a reason that says what was seen, and the
    confidence 1 - bound / (2 stall_max_rpm) (0.5..1). `confident` stays False: a stall is not a
    count of the ripple (the consumers of counted speeds, check_ratio, count_sd_rpm, span_reference,
    are unchanged); the ripple reference labels it (reference.swap). Needs a prior and rpm_per_A
    (Ra / Ke); without them, or with opts.stall_max_rpm 0, est is returned with `stall` False and
    `rpm_bound` NaN everywhere. est: estimate()'s DataFrame (after count_steady_spans). Returns a copy."""
    est = est.copy()
    est["stall"] = False
    est["rpm_bound"] = np.nan
    if not opts.stall_max_rpm > 0 or rpm_per_A is None or not np.isfinite(rpm_per_A) or duty is None:
        return est
    fs = bursts.sample_hz
    per_rev_out = opts.ripples_per_rev * opts.gear_ratio
    keys = est["key"].to_numpy()
    prior = est["rpm_prior_used"].to_numpy(float)
    sd_above = est["prior_sd_above"].to_numpy(float)
    i_mean = est["i_mean_A"].to_numpy(float)
    duty = np.asarray(duty, float)
    for a, e in steady_spans(bursts, duty, keys, opts, STALL_KEYS):
        if not (np.isfinite(prior[a:e]).all() and np.isfinite(i_mean[a:e]).all() and (i_mean[a:e] >= opts.floor_A).all()):
            continue
        lengths = np.array([len(c) for c in bursts.codes[a:e]])
        S = float(lengths.sum()) / fs
        rpm_floor = speed_floor_rpm(float(np.median(lengths)) / fs, opts)
        pr, sa = float(np.median(prior[a:e])), float(np.median(sd_above[a:e]))
        n_up = pr + opts.stall_prior_z * math.hypot(sa, opts.prior_rel_sd * max(pr, 0.0))
        if not n_up < rpm_floor:  # 1. the prior lets the shaft turn fast enough for a window's count
            continue
        n_hi = max(_upper_speed(pr, sa, opts.prior_rel_sd, opts.max_prior_z), rpm_floor)
        f_min, f_max = opts.stall_cycles / S, min(n_hi * per_rev_out / 60.0, 0.45 * fs)
        f, p = _spectrum(np.concatenate([bursts.current_A(k) for k in range(a, e)]), fs, pad=4)
        band = (f >= f_min) & (f <= f_max)
        if band.sum() < 16:
            continue
        snr = float(p[band].max() / max(float(np.median(p[band])), 1e-30))
        if snr >= opts.stall_snr:  # 2. a line in the band: something turns
            continue
        bound = 60.0 * opts.stall_cycles / (per_rev_out * S) + rpm_per_A * float(i_mean[a:e].max() - i_mean[a:e].min())
        if bound > opts.stall_max_rpm:
            continue
        idx = est.index[a:e]
        reason = (f"{REASONS['stall']}: at duty {duty[a]:g} with {1000 * float(i_mean[a:e].mean()):.0f} mA over "
                  f"{S:.1f} s ({e - a} windows) the strongest line from {f_min:.2f} to {f_max:.1f} Hz is "
                  f"{snr:.1f}x the band's median power (under {opts.stall_snr:g}); the prior {pr:.1f} RPM + "
                  f"{opts.stall_prior_z:g} sd = {n_up:.1f} RPM, under the speed floor {rpm_floor:.1f} RPM; "
                  f"|n| < {bound:.2f} RPM")
        est.loc[idx, ["rpm", "f_Hz", "cycles"]] = 0.0
        est.loc[idx, "snr"] = snr
        est.loc[idx, "confidence"] = 1.0 - bound / (2.0 * opts.stall_max_rpm)
        est.loc[idx, "key"] = "stall"
        est.loc[idx, "reason"] = reason
        est.loc[idx, "stall"] = True
        est.loc[idx, "rpm_bound"] = bound
    return est


def identity_of_recording(est, opts: Options):
    """The line's identity over a whole recording: where most of the windows whose lines form a
    rotation comb (est's `multiple` > 0; not those named `damaged`) put the strongest line at another multiple than
    opts.ripples_per_rev, the user's figure is wrong for this motor, and a window without a comb of
    its own cannot show that its line is the ripple (its prior, (V - I Ra) / Ke with a Ke calibrated
    under the same figure, agrees with any multiple): every confident row without its own comb at
    ripples_per_rev is then `multiple`, not confident, with the multiple the comb windows show.
    est: speed_of_log's DataFrame. Returns a copy."""
    est = est.copy()
    m = est["multiple"].to_numpy(int)
    shown = (m > 0) & (est["key"].to_numpy() != "damaged")  # a damaged commutator's even lines are not the comb
    other = shown & (m != opts.ripples_per_rev)
    if not shown.any() or other.sum() <= 0.5 * shown.sum():
        return est
    vals, counts = np.unique(m[other], return_counts=True)
    top = int(vals[np.argmax(counts)])
    demote = est["confident"].to_numpy(bool) & (m != opts.ripples_per_rev)
    idx = est.index[demote]
    est.loc[idx, "confident"] = False
    est.loc[idx, "confidence"] = 0.0
    est.loc[idx, "key"] = "multiple"
    est.loc[idx, "reason"] = (f"{REASONS['multiple']}: the ripple is {top} per revolution, not the "
                              f"{opts.ripples_per_rev} given, in {int((m == top).sum())} of the {int(shown.sum())} "
                              "windows of this recording whose lines form a rotation comb; this window shows none "
                              "of its own")
    return est


def span_reference(est, rpm_ref) -> np.ndarray:
    """The encoder speed each row's ripple speed is compared with: its own window's reading, or for
    a row counted in a span of steady windows (count_steady_spans) the mean of the encoder over the
    span's windows, because the span's count is the mean speed over them (at 5 RPM one 0.5 s window
    of this bench's encoder holds 8 counts, so one window's reading steps by 12 %). NaN readings
    (glitches left out) are left out of a span's mean; a span with none is NaN."""
    ref = np.asarray(rpm_ref, float)
    out = ref.copy()
    if "span_first" not in est:
        return out
    first = est["span_first"].to_numpy()
    for a in np.unique(first[est["span"].to_numpy() > 1]):
        m = first == a
        out[m] = np.nanmean(ref[m]) if np.isfinite(ref[m]).any() else np.nan
    return out


STANDING = "standing"
STANDING_REASON = ("standing: the drive off (duty 0) and no current, so the open terminals show the back-EMF, "
                   "and |V| is under the threshold: 0 RPM from the back-EMF, not counted")
STANDING_CONFIDENCE = 1.0  # the back-EMF bounds the speed to |V| / Ke, under a quarter RPM: no count is surer


def standing(est, duty, v_V, opts: Options) -> np.ndarray:
    """The windows where the shaft stands by the back-EMF, one bool per row of est (estimate()'s
    rows; duty and v_V per window): the drive off (duty 0, est's `coasting`), no armature current
    (the burst's mean under opts.floor_A), so nothing flows through the winding and the terminals
    are open, and the terminal voltage, which is then the back-EMF Ke w, under opts.standing_V in
    magnitude. A speed measurement from the back-EMF where the ripple has nothing to count (no
    current, no ripple), valid for a driver that leaves the terminals open when off (the bench's
    low-side switch with its freewheel diode, which conducts only while current flows); a driver
    that brakes (shorts the terminals) makes V = 0 while the shaft turns, and drives current,
    which the current condition refuses where it is above the floor. Used by the ripple
    reference (reference.swap) to label those rows 0 RPM with STANDING_CONFIDENCE."""
    duty = np.asarray(duty, float)
    v = np.asarray(v_V, float)
    i = est["i_mean_A"].to_numpy(float)
    if not opts.standing_V > 0:
        return np.zeros(len(est), bool)
    return ((est["key"].to_numpy() == "coasting") & (duty == 0.0) & np.isfinite(v) & (np.abs(v) < opts.standing_V)
            & np.isfinite(i) & (np.abs(i) < opts.floor_A))


def count_sd_rpm(est) -> np.ndarray:
    """The standard uncertainty (RPM) of each window's counted speed in est (estimate() or
    speed_of_log's DataFrame), NaN where the count is not confident; for an observer that takes
    the count as a measurement (hpddo compare's "EKF + ripple"). Two parts: the speed's own
    movement inside the window (the larger of the quarters' spread and the current's, a range,
    whose standard deviation is range / sqrt(12) for a speed anywhere within it), and the
    count's resolution: the phase at each end of the counted cycles known to 1 / sqrt(snr) rad
    (the line's amplitude over the noise's), sqrt(2) / (2 pi cycles sqrt(snr)) of the speed, the
    cycles of the whole span where windows were counted together. On the twin (docs/ripple-compare.md,
    "Ripple counting as a peer in `hpddo compare`") the errors against the true window-mean speed
    are 0.4-0.6 of this in RMS (sweep, load, long, unseen, hot), at most 1.9 of it in 99 % of the
    rows: the weight errs on the side of caution."""
    rpm = est["rpm"].to_numpy(float)
    move = np.fmax(est["spread"].to_numpy(float), np.nan_to_num(est["spread_current"].to_numpy(float)))
    span = est["span"].to_numpy(float) if "span" in est else np.ones(len(est))
    cycles = est["cycles"].to_numpy(float) * span
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.hypot(move / math.sqrt(12.0), math.sqrt(2.0) / (2 * math.pi * cycles * np.sqrt(est["snr"].to_numpy(float))))
    return np.where(est["confident"].to_numpy(bool) & np.isfinite(rel) & (cycles > 0), np.abs(rpm) * rel, np.nan)


def rpm_per_amp(ra_ohm: float, ke_vs_per_rad: float) -> float:
    """Ra / Ke in RPM per A: the speed a change of the armature current costs at constant voltage."""
    return ra_ohm / ke_vs_per_rad * 60.0 / (2 * math.pi)


def calibrate_ke(bursts, duty, v_V, i_A, ra_ohm: float, opts: Options):
    """Ke (V s/rad, output shaft) for the back-EMF prior without an encoder: the ripple speed
    of the windows where the comb alone (no prior) gives a confident count, against
    V - I Ra; their median, each window weighted by (w / u)^2 (u: the voltage the prior does
    not know, m2_prior_sd_rpm). Returns (ke, windows used)."""
    df = estimate(bursts, duty, None, opts)
    ok = df["confident"].to_numpy() & (df["rpm"].to_numpy() > 0)
    if ok.sum() == 0:
        return math.nan, 0
    w = df["rpm"].to_numpy()[ok] * 2 * math.pi / 60.0
    i = np.asarray(i_A, float)[ok]
    e = np.asarray(v_V, float)[ok] - i * ra_ohm
    # each window's E / w is off by the voltage the prior does not know (u, m2_prior_sd_rpm) over w:
    # the median weighted by (w / u)^2, so that slow, loaded windows (and a fixed line counted
    # while the shaft stands) weigh little
    u = np.hypot(opts.prior_unmodelled_V, opts.prior_ra_rel * ra_ohm * np.abs(i))
    ke = e / w
    order = np.argsort(ke)
    cw = np.cumsum(((w / u) ** 2)[order])
    return float(ke[order][np.searchsorted(cw, 0.5 * cw[-1])]), int(ok.sum())


def _group_sum(group, x) -> np.ndarray:
    """x summed over each row's group, per row."""
    import pandas as pd
    return pd.Series(np.asarray(x, float)).groupby(np.asarray(group)).transform("sum").to_numpy()


def encoder_step_from_readings(rpm_ref) -> float:
    """One encoder count per window in RPM as the readings themselves show it: the smallest
    difference between two distinct readings (a counted encoder reads whole counts per window; a
    period-timed one gives differences far below any count, and then a step of about 0)."""
    v = np.unique(np.round(np.asarray(rpm_ref, float)[np.isfinite(rpm_ref)], 9))
    d = np.diff(v)
    return float(d.min()) if len(d) else 0.0


def check_ratio(df, rpm_ref, window_s: float, opts: Options, tol: float = 0.001,
                encoder_step_rpm: float | None = None):
    """With an encoder on the output shaft: the ripples per output revolution measured over the
    confident windows (the sum of counted cycles over the sum of encoder revolutions; windows
    whose own ratio departs from the median by more than TRIM left out and counted), the gear
    ratio it implies for the user's ripples per motor revolution, and a statement. The ratio is
    called the nameplate's unless it departs by more than tol and by more than three standard
    uncertainties of the encoder's own resolution over the windows used: each window's reading
    is off by up to one count (encoder_step_rpm, RPM per count and window: the log header's
    where it declares the encoder, else encoder_step_from_readings), a standard deviation of
    step / sqrt(6) per window, independent across windows, which a slow run's few counts make
    large (118 windows at 5 RPM with a 0.62 RPM step: 0.33 %)."""
    ref = np.asarray(rpm_ref, float)
    ok = df["confident"].to_numpy() & np.isfinite(ref) & (ref > 0)
    if ok.sum() == 0:
        return {"windows": 0, "statement": "no confident window with an encoder speed: the ratio is not checked"}
    f_hz = df["f_Hz"].to_numpy()
    # a window whose own ratio departs from the median by more than TRIM is an encoder glitch
    # (extra counts) or a count gone wrong, not the gear: left out, and counted. The windows of a
    # span counted as one (count_steady_spans) are one count: their ratio is the span's, the
    # cycles over the encoder's revolutions summed over its windows (one slow window's encoder
    # reading steps by 12 % at 5 RPM)
    group = df["span_first"].to_numpy() if "span_first" in df else np.arange(len(df))
    f_sum = _group_sum(group, np.where(ok, f_hz, 0.0))
    ref_sum = _group_sum(group, np.where(ok, ref, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        per = np.where(ok, f_sum / ref_sum * 60.0, np.nan)
    first = np.r_[True, group[1:] != group[:-1]]  # the median over counts, each span once
    med = np.nanmedian(per[first & ok]) if (first & ok).any() else np.nanmedian(per)
    trimmed = ok & (np.abs(per / med - 1.0) > TRIM)
    if not (ok & ~trimmed).any():  # the windows' ratios fall into clusters: none lies near their median
        lo, hi = float(np.nanmin(per[ok])), float(np.nanmax(per[ok]))
        return {"windows": 0, "left_out": int(trimmed.sum()),
                "statement": (f"the {int(ok.sum())} confident windows do not agree on the ripples per output "
                              f"revolution ({lo:.2f} to {hi:.2f}, none within {TRIM:.0%} of their median "
                              f"{med:.2f}): counts on different lines, so the gear ratio is not checked")}
    ok = ok & ~trimmed
    cycles = float(np.sum(f_hz[ok]) * window_s)
    revs = float(np.sum(ref[ok]) / 60.0 * window_s)
    per_rev = cycles / revs
    ratio = per_rev / opts.ripples_per_rev
    rel = ratio / opts.gear_ratio - 1.0
    step = encoder_step_from_readings(ref[ok]) if encoder_step_rpm is None else float(encoder_step_rpm)
    rel_sd = math.sqrt(ok.sum()) * step / math.sqrt(6.0) / float(np.sum(ref[ok]))  # of the encoder's revolutions
    tol_used = max(tol, 3.0 * rel_sd)
    out = {"windows": int(ok.sum()), "left_out": int(trimmed.sum()), "ripples_per_output_rev": per_rev, "gear_ratio_measured": ratio,
           "gear_ratio_given": opts.gear_ratio, "relative": rel, "encoder_step_rpm": step,
           "relative_sd_encoder": rel_sd, "tolerance": tol_used}
    family = [m for m in (2.0, 3.0, 0.5, 1 / 3, 6.0, 1 / 6) if abs(rel + 1 - m) < 0.02 * m]
    if family:
        out["statement"] = (f"the data give {per_rev:.2f} ripples per output revolution, {rel + 1:.3g}x the "
                            f"{opts.ripples_per_rev} x {opts.gear_ratio:g} given: the ripples per motor revolution "
                            "(2 x segments for 2 brushes) are likely wrong, not the gear ratio")
    elif abs(rel) > tol_used:
        out["statement"] = (f"the gear ratio is {ratio:.3f}:1, not the nameplate's {opts.gear_ratio:g}:1 "
                            f"({rel:+.2%}, beyond {tol_used:.2%}; {per_rev:.2f} ripples per output revolution over "
                            f"{ok.sum()} windows, {opts.ripples_per_rev} per motor revolution)")
    else:
        why = (f"the encoder's resolution over these {ok.sum()} windows, {step:.3g} RPM a count" if tol_used > tol
               else "the check's own tolerance")
        out["statement"] = (f"the gear ratio {opts.gear_ratio:g}:1 agrees with the data ({ratio:.3f}:1, "
                            f"{rel:+.2%}, within {tol_used:.2%}: {why})")
    return out


@dataclasses.dataclass(frozen=True)
class ModelPrior:
    """A trained model's identified M2 as the back-EMF prior (hpddo ripple --model, --prior-model of
    --reference ripple; cli.options.prior_model_of reads it): its
    physics (model.physics.PhysicsParams: Ra, Ke and the named effects it was trained with), and
    where it came from, for the statement."""

    physics: object
    source: str

    def rpm(self, path, df, meta: dict) -> np.ndarray:
        """n_M2 of every row of one log (its rows df, metadata meta) with the model's effects and the
        observer's lag and thermal rules (train.physics_rpm): the rows as they are, none filtered."""
        from ..logs.dataset import Recording
        from . import train
        rows = df if "seq" in df else df.assign(seq=np.arange(len(df), dtype=np.int64))
        rec = Recording(name=str(path), source=pathlib.Path(path), meta=dict(meta), df=rows, removed=[], n_train=0)
        return np.asarray(train.physics_rpm(rec, self.physics), float)

    def to_json(self) -> dict:
        """Where the prior came from, as summary.json and metrics.json / diagnosis.json record it."""
        return {"folder": self.source, "effects": self.physics.effect_names(),
                "ra_ohm": float(self.physics.ra_ohm), "ke_vs_per_rad": float(self.physics.ke_vs_per_rad)}

    def describe(self) -> str:
        effects = self.physics.effect_names()
        return f"model {self.source} (M2 with {', '.join(effects) if effects else 'no effects'})"


def _number_or_nan(text) -> float:
    """A metadata value as a number; NaN where it is missing or not one."""
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def speed_of_log(path, df, meta: dict, opts: Options, ra_ohm: float | None = None,
                 ke_vs_per_rad: float | None = None, bursts=None, model: ModelPrior | None = None,
                 rpm_range=None):
    """The ripple speed of every window of one bench log (its rows df, metadata meta) from the
    bursts beside it (`<condition>.ripple.csv`): (estimate DataFrame, one row per burst, with
    `row`, the index of its window in df, and `rpm_prior`; Ke of the prior, where it came
    from). The prior is M2 without effects, (V - I Ra) / Ke: Ke the user's, else calibrated
    from the ripple (calibrate_ke); Ra the user's, else the log's ra_ohm metadata.
    InputError where the bursts are missing, do not match the log, or Ra is unknown. bursts:
    the log's bursts already read (logs.ripple.read), for a caller that counts them twice.
    model: a trained model's M2 with its named effects as the prior instead (ModelPrior; its Ra and
    Ke give the prior's spread, m2_prior_sd_rpm, and the speed a change of current means); not with
    ra_ohm or ke_vs_per_rad. The windows are counted one at a time (estimate), over spans of steady
    windows (count_steady_spans), with the settled tails where opts.settled_tail, and the stalls named
    (count_stalls: columns `stall` and `rpm_bound`). Without Ra (no ra_ohm, no metadata, no model) there
    is no back-EMF prior: rpm_range (lo, hi) RPM is the prior, or none (ripple_range.range_prior), Ke
    NaN. Where rpm_range is given, a confident count outside it is not confident (within_range). Free-running
    bursts have their PWM-synchronous average removed first (ripple_sync.prepare)."""
    from ..logs import ripple as rf
    from ..logs.errors import InputError
    from . import ripple_range

    bpath = rf.path_for(path)
    if bursts is None and not bpath.exists():
        raise InputError(f"{path}: no current bursts beside it ({bpath.name}); record them in the ripple "
                         "mode (hpddo twin --ripple-hz, docs/ripple.md)")
    b = ripple_sync.prepare(rf.read(bpath) if bursts is None else bursts, str(bpath))
    seq = df["seq"].to_numpy() if "seq" in df else np.arange(len(df))
    pos = {int(s): k for k, s in enumerate(seq)}
    rows = [pos.get(int(s)) for s in b.seq]
    if any(r is None for r in rows):
        raise InputError(f"{bpath}: a burst's seq is not in {pathlib.Path(path).name}")
    duty, v, i = (df[c].to_numpy()[rows] for c in ("duty", "v_V", "i_A"))
    if model is not None:
        if ra_ohm is not None or ke_vs_per_rad:
            raise ValueError("a model's M2 is the prior with its own Ra and Ke: not with ra_ohm or ke_vs_per_rad")
        ra, ke, ke_from = float(model.physics.ra_ohm), float(model.physics.ke_vs_per_rad), model.describe()
        if not (ke > 0 and math.isfinite(ra)):
            raise InputError(f"{model.source}: the model's Ke {ke:g} V s/rad or Ra {ra:g} ohm cannot be a prior")
        prior = model.rpm(path, df, meta)[rows]
    else:
        ra = ra_ohm if ra_ohm is not None else _number_or_nan(meta.get("ra_ohm"))
        if not math.isfinite(ra):  # no back-EMF prior: the user's speed range, or none
            ke, ke_from = math.nan, "no Ra: " + ("the speed range given is the prior" if rpm_range else "no prior")
        elif ke_vs_per_rad:
            ke, ke_from = float(ke_vs_per_rad), "user"
        else:
            ke, n_ke = calibrate_ke(b, duty, v, i, ra, opts)
            ke_from = f"ripple ({n_ke} windows)"
        prior = m2_prior_rpm(v, i, ra, ke) if math.isfinite(ke) else None
    per_A = rpm_per_amp(ra, ke) if math.isfinite(ke) and math.isfinite(ra) else None
    prior_sd = m2_prior_sd_rpm(v, i, ra, ke, opts) if prior is not None else None
    if prior is None and rpm_range is not None:
        prior, prior_sd = ripple_range.range_prior(rpm_range, len(rows))
    est = estimate(b, duty, prior, opts, prior_sd, per_A)
    est = count_settled_tails(b, duty, est, opts, per_A)
    est = count_steady_spans(b, duty, est, opts, per_A)
    est = count_stalls(b, duty, est, opts, per_A if prior is not None else None)
    est = identity_of_recording(est, opts)
    est = ripple_range.within_range(est, rpm_range)
    est.insert(1, "row", np.asarray(rows, np.int64))
    est["rpm_prior"] = np.nan if prior is None else prior
    return est, ke, ke_from
