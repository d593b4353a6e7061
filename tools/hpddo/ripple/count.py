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
   (comb.py): where the window's lines form a comb of the rotation frequency, the
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

This module holds steps 1-4 (`estimate_window`, `estimate`), the settled tails of a `changing`
window, and a count's standard uncertainty; spans.py, stall.py and log.py the rest.
"""
from __future__ import annotations

import math

import numpy as np

from . import comb as rc
from . import sync
from .line import ALTERNATIVES, FAMILY, FAMILY_WEIGHT, line_power, spectrum
from .options import REASONS, Options
from .prior import prior_like


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
    means = part_means(x0, fs, f_Hz, 4)
    return rpm_per_A * (max(means) - min(means)) / max(abs(rpm), 1e-12)


def part_means(x0, fs, f_Hz, parts) -> list:
    """The current's mean over each part of x0 (A) with the ripple's lines fitted out (_current_spread): parts, a
    number of equal parts or the indices where the parts after the first begin (np.array_split's)."""
    n = len(x0)
    t = np.arange(n) / fs
    cols = [np.ones(n)]  # the mean, fitted with the lines (a line of few cycles does not average out)
    for h in (1.0, 2.0) + tuple(1.0 / d for d in FAMILY):
        if h * f_Hz * n / fs >= 1.0 and h * f_Hz < fs / 2:
            cols += [np.cos(2 * math.pi * h * f_Hz * t), np.sin(2 * math.pi * h * f_Hz * t)]
    a = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(a, x0, rcond=None)
    x = x0 - a[:, 1:] @ coef[1:]
    return [float(q.mean()) for q in np.array_split(x, parts)]


def spread_noise(cycles, snr):
    """The relative spread of the quarters' speeds that the count's own noise makes, as one
    quarter's standard deviation: the line's phase read to 1 / sqrt(snr) rad (its amplitude over
    the noise's) at each end of a quarter of cycles / 4 ripples, so a quarter's speed to
    sqrt(2) / (2 pi (cycles / 4) sqrt(snr)) of itself; inf without cycles or a line."""
    cycles, snr = np.asarray(cycles, float), np.asarray(snr, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        sd = math.sqrt(2.0) / (2 * math.pi * (cycles / 4.0) * np.sqrt(snr))
    return np.where((cycles > 0) & (snr > 0), sd, np.inf)


def wide_snr(f, p_max, p, f_Hz, res, f_lo, f_hi, n_res):
    """The line at f_Hz over the median power of a wide band around it (n_res resolutions res, shifted
    to lie inside f_lo .. f_hi): a floor the lines of the ripple's family, mains and PWM cannot move,
    nor one noisy bin beside a line of few cycles. NaN where f_lo .. f_hi holds fewer than n_res
    resolutions (no floor that wide to be had)."""
    width = n_res * res
    if f_hi - f_lo < width:
        return math.nan
    a = min(max(f_Hz - width / 2, f_lo), f_hi - width)
    sel = (f >= a) & (f <= a + width)
    floor = float(np.median(p[sel]))
    return float(line_power(f, p_max, f_Hz)) / max(floor, 1e-30)


def allowed_spread(cycles, snr, snr_wide, opts: Options) -> float:
    """The quarters' spread (relative) under which a window's count is steady: opts.max_spread, and on
    top of it opts.spread_noise_z sd of the count's own noise (spread_noise) where the line stands
    clear of the floor (snr_wide, wide_snr, at least opts.spread_noise_snr; a line nearer the noise,
    the noise of a standing shaft among them, keeps max_spread alone), at most half the band's
    half-width ((band - 1) / 2: a line that moved more has left the band's flat part)."""
    if not (np.isfinite(snr_wide) and snr_wide >= opts.spread_noise_snr):
        return opts.max_spread
    extra = opts.spread_noise_z * float(spread_noise(cycles, snr))
    return float(min(opts.max_spread + extra, max(opts.max_spread, (opts.band - 1.0) / 2.0)))


def estimate_window(bursts, k, duty, rpm_prior, opts: Options, prior_before=None, prior_sd=None, rpm_per_A=None,
                    prior_glitch=0.0, unplaced_hum=True, turning_given=False):
    """One window: dict with rpm (count), rpm_fft (one FFT peak in the band), f_Hz (the counted
    frequency), f_strongest_Hz (the strongest line of the spectrum, for comparison), cycles, snr, spread,
    confidence (0..1), reason ('' when confident), key (REASONS key or ''). prior_before: the
    previous window's prior (RPM), the speed where this window starts, bounding a tracked count.
    prior_sd: the prior's voltage-borne sd at this window (RPM), one figure or (below, above)
    (m2_prior_sd_rpm); None: 0 (Ke's relative error, opts.prior_rel_sd, alone). rpm_per_A: Ra / Ke
    in RPM per A, the speed change a change of current means at constant duty (_current_spread;
    None: not checked). prior_glitch: the part of prior_sd (RPM, in quadrature) that only allows for a glitch
    of V or I beside the window (estimate: its own prior against the median of three); a line at a multiple of
    50 or 60 Hz where the file declares no mains must lie within max_prior_z of the prior without it to count
    as placed by the prior (sync.fixed_line). unplaced_hum: whether a line that neither a comb nor the prior
    places is taken for hum at an undeclared 50 or 60 Hz multiple (sync.fixed_line); False for calibrate_ke,
    which keeps only the windows whose back-EMF shows the shaft turning. The prior places a line only where it
    also refuses a standing shaft (0 RPM beyond max_prior_z of its sd), or where turning_given: the user's
    speed range, whose lower end is above 0, says the shaft turns (ripple.speed_range)."""
    from scipy import signal

    fs = bursts.sample_hz
    out = dict(rpm=math.nan, rpm_fft=math.nan, f_Hz=math.nan, f_strongest_Hz=math.nan, cycles=math.nan, snr=math.nan,
               spread=math.nan, spread_current=math.nan, spread_allowed=math.nan, snr_wide=math.nan,
               i_mean_A=math.nan, rot_hz=math.nan, multiple=0, rot1_rel=math.nan, rot2_rel=math.nan,
               fault_rel=math.nan, confidence=0.0, reason="", key="")
    x0 = bursts.current_A(k)
    n = len(x0)
    if n:  # (the mean current of a burst too short to count is read all the same: the log's floor count says it)
        out["i_mean_A"] = float(x0.mean())
    if n < 16:
        out.update(key="few_cycles", reason=REASONS["few_cycles"])
        return out
    i_mean = out["i_mean_A"]
    if duty is not None and duty == 0.0:
        out.update(key="coasting", reason=REASONS["coasting"])
        return out
    if abs(i_mean) < opts.floor_A and sync.holds_mean(bursts):
        out.update(key="floor", reason=f"{REASONS['floor']} ({i_mean * 1000:.0f} mA < {opts.floor_A * 1000:.0f} mA)")
        return out
    T = n / fs
    per_rev_out = opts.ripples_per_rev * opts.gear_ratio  # ripples per output revolution

    def rpm_of(f_Hz):
        return f_Hz * 60.0 / per_rev_out

    f_prior = rpm_prior * per_rev_out / 60.0 if rpm_prior is not None and np.isfinite(rpm_prior) else math.nan
    sd_lo, sd_hi = (np.nan_to_num(np.broadcast_to(np.asarray(prior_sd, float), (2,)), nan=0.0) * per_rev_out / 60.0
                    if prior_sd is not None else (0.0, 0.0))
    glitch_hz = float(np.nan_to_num(prior_glitch)) * per_rev_out / 60.0
    sd_lo_own, sd_hi_own = (math.sqrt(max(sd * sd - glitch_hz * glitch_hz, 0.0)) for sd in (sd_lo, sd_hi))

    # 2. the line: comb evidence weighted by the prior
    f, p = spectrum(x0, fs)
    res = 1.0 / T
    from scipy.ndimage import maximum_filter1d
    step = f[1] - f[0]
    p_max = maximum_filter1d(p, size=max(1, int(round(res / step))) | 1)
    f_lo = max(2.0 * res, 0.5)
    f_hi = fs / 2.0 / 2.2
    band_all = (f >= f_lo) & (f <= f_hi)
    if not band_all.any():  # a sample rate or window too short for any ripple's cycles
        out.update(key="few_cycles", reason=f"{REASONS['few_cycles']} (at {fs:g} Hz over {T:.3g} s no frequency lies "
                                            f"between {f_lo:.3g} and {f_hi:.3g} Hz)")
        return out
    grid = np.geomspace(f_lo, f_hi, 4000)

    def evidence(g):
        e = line_power(f, p_max, g)
        for d in FAMILY:
            gd = g / d
            e = e + FAMILY_WEIGHT * np.where(gd >= 1.5 * res, line_power(f, p_max, gd), 0.0)
        return e

    out["f_strongest_Hz"] = float(f[band_all][np.argmax(p[band_all])])  # one FFT peak, no prior, no family
    found = rc.lines(f, p, f_lo, f_hi, res, opts.min_snr)
    found = rc.without_fixed(found, bursts, res)
    pwm = rc.pwm_of(bursts)  # (a free-running burst's in-band PWM, or None)
    comb = rc.rotation_comb(found, res, opts.min_snr, rc.fixed_hz_of(bursts), pwm, rc.mains_of(bursts))
    if comb is not None:  # the line's identity from the data: the comb of rotation lines
        out.update(rot_hz=comb.rot_hz, multiple=comb.multiple)
        health = rc.health(f, p_max, comb.rot_hz, comb.commutation.hz, res, p, found, opts.min_snr)
        out["rot1_rel"], out["rot2_rel"], out["fault_rel"] = health
        if rc.damaged(*health):
            out.update(key="damaged", f_Hz=comb.commutation.hz, snr=comb.commutation.snr,
                       reason=rc.damaged_reason(REASONS["damaged"], *health, comb.rot_hz))
            return out
        if comb.multiple != opts.ripples_per_rev:
            out.update(key="multiple", f_Hz=comb.commutation.hz, snr=comb.commutation.snr,
                       rpm=comb.rot_hz * 60.0 / opts.gear_ratio,
                       reason=f"{REASONS['multiple']}: the ripple is {comb.multiple} per revolution, not the "
                              f"{opts.ripples_per_rev} given (rotation lines {comb.rot_hz:.2f} Hz apart, the "
                              f"strongest at {comb.multiple} x, {comb.commutation.hz:.1f} Hz)")
            return out
    ev = evidence(grid)
    like, z = prior_like(grid, f_prior, sd_lo, sd_hi, opts.prior_rel_sd)
    post = ev * like
    j = int(np.argmax(post))
    f_star = float(grid[j]) if comb is None else comb.commutation.hz
    z_star = float(z[j]) if comb is None else float(prior_like([f_star], f_prior, sd_lo, sd_hi, opts.prior_rel_sd)[1][0])
    # the local noise floor: the median power from f*/2 to 2 f*, lines excluded by the median
    sel = (f > f_star / 2) & (f < 2 * f_star)
    floor = float(np.median(p[sel])) if sel.sum() > 8 else float(np.median(p))
    snr = line_power(f, p_max, f_star) / max(floor, 1e-30)
    out["snr"] = float(snr)
    out["snr_wide"] = wide_snr(f, p_max, p, f_star, res, f_lo, f_hi, opts.spread_noise_res)
    if snr < opts.min_snr or (comb is None and post[j] <= 0):
        out.update(key="not_found", reason=REASONS["not_found"], f_Hz=f_star)
        return out
    if abs(z_star) > opts.max_prior_z:  # a line the back-EMF cannot hold: not the ripple
        out.update(key="far", f_Hz=f_star, reason=f"{REASONS['far']} ({f_star:.1f} Hz, {rpm_of(f_star):.1f} RPM, "
                   f"{z_star:+.1f} sd from the prior's {rpm_prior:.1f} RPM)")
        return out
    def line_placed(f_hz):  # a comb or the prior places the line (sync.fixed_line): the prior without its glitch
        # allowance holds the line and refuses a standing shaft (0 RPM further than max_prior_z of its sd), whose
        # current holds the hum alone
        if not unplaced_hum or comb is not None:
            return True
        if not np.isfinite(f_prior):
            return False
        with np.errstate(divide="ignore", invalid="ignore"):
            z_line, z_still = prior_like([f_hz, 0.0], f_prior, sd_lo_own, sd_hi_own, opts.prior_rel_sd)[1]
        return abs(float(z_line)) <= opts.max_prior_z and (turning_given or not abs(float(z_still)) <= opts.max_prior_z)

    # a PWM or mains line, or a refused fold; beside a mains line, the same line within a resolution of the fit's
    fixed = sync.fixed_line(bursts, k, f_star, res, line_placed(f_star), x0, agree_hz=res)
    if fixed:
        out.update(key=fixed[0], f_Hz=f_star, reason=fixed[1])
        return out
    # rivals: every line inside the prior's spread (max_prior_z of its sd) as strong as opts.ambiguity of the
    # chosen one's power, the comb's own lines but where the comb has placed them (mains and PWM multiples,
    # a neighbouring rotation line where no comb is seen); weighed by their power alone, so that a prior
    # which moves cannot turn one of them into a confident answer
    placed = [ln.hz for ln, _ in comb.lines] if comb is not None else []

    def in_spread(hz):
        return abs(prior_like([hz], f_prior, sd_lo, sd_hi, opts.prior_rel_sd)[1][0]) <= opts.max_prior_z

    riv = rc.rivals(found, f_star, res, in_spread, opts.ambiguity, placed)
    if riv:
        out.update(key="rival", f_Hz=f_star, reason=f"{REASONS['rival']} ({f_star:.1f} Hz or {riv[0].hz:.1f} Hz, "
                   f"{riv[0].power / max(line_power(f, p_max, f_star), 1e-300):.2f} of its power)")
        return out
    # under a free-running PWM, a line and its PWM sideband inside the spread, whatever their powers
    # (comb.SIDEBAND_SHARE): where no comb places the line, which of the two is the commutation neither the powers
    # nor the prior can tell
    partners = rc.sideband_partners(found, f_star, res, pwm, in_spread) if comb is None else []
    if partners:
        out.update(key="rival", f_Hz=f_star, reason=f"{REASONS['rival']} ({f_star:.1f} Hz or {partners[0].hz:.1f} Hz: "
                   f"each the other's sideband of the {pwm[0]:g} Hz PWM, "
                   f"{partners[0].power / max(line_power(f, p_max, f_star), 1e-300):.2f} of its power)")
        return out
    # ... and where that partner does not show, the chosen line's mirror sideband may: then it may be a sideband of
    # a commutation line under the noise
    mirrors = rc.hidden_line_mirrors(found, f_star, res, pwm, in_spread) if comb is None else []
    if mirrors:
        g, ln = mirrors[0]
        out.update(key="rival", f_Hz=f_star, reason=f"{REASONS['rival']} ({f_star:.1f} Hz may be a sideband of the "
                   f"{pwm[0]:g} Hz PWM around a line at {g:.1f} Hz under the noise: its mirror at {ln.hz:.1f} Hz shows, "
                   f"{ln.power / max(line_power(f, p_max, f_star), 1e-300):.2f} of its power)")
        return out
    # ... and where no comb places the line, any other resolved line inside the prior's spread, whatever its power: the
    # prior alone cannot say which of two lines is the ripple, and the stronger may be another's (comb.unplaced_rivals).
    # Without a prior the spread is the whole band, whose noise reaches a resolved line's power now and then (1 window
    # in 10 of a lone 150 Hz line); such windows are checked over the recording instead (line.identity_of_recording)
    unplaced = (rc.unplaced_rivals(found, f_star, res, in_spread, opts.min_snr, ALTERNATIVES, rc.mains_of(bursts))
                if comb is None and math.isfinite(f_prior) else [])
    if unplaced:
        ln = unplaced[0]
        out.update(key="rival", f_Hz=f_star, reason=f"{REASONS['rival']} ({f_star:.1f} Hz or {ln.hz:.1f} Hz, "
                   f"{ln.power / max(line_power(f, p_max, f_star), 1e-300):.2g} of its power: no rotation comb places "
                   "either, and power does not name the ripple"
                   + ("; one of them lies on a multiple of 50 or 60 Hz: where that is hum, declare the mains (hpddo "
                      "import --mains-hz)" if not math.isfinite(bursts.mains_hz)  # (a declared mains: nothing to add)
                      and (rc.on_mains(f_star, res) or rc.on_mains(ln.hz, res)) else "") + ")")
        return out
    # rivals in the family where no comb places the line: the data's own evidence at f* x r, weighted by the prior
    alt = ALTERNATIVES
    alt_f = np.array([f_star * r for r in alt])
    ok = (alt_f > f_lo) & (alt_f < f_hi)
    if comb is None and ok.any():
        alt_ev = evidence(alt_f[ok])
        alt_like, _ = prior_like(alt_f[ok], f_prior, sd_lo, sd_hi, opts.prior_rel_sd)
        rival = float(np.max(alt_ev * alt_like / max(like[j], 1e-300)))
        if rival >= opts.ambiguity * float(ev[j]):
            r = alt_f[ok][int(np.argmax(alt_ev * alt_like))]
            out.update(key="ambiguous", f_Hz=f_star,
                       reason=f"{REASONS['ambiguous']} ({f_star:.1f} Hz or {r:.1f} Hz)")
            return out
    if comb is None:  # the health lines where the user's ripples per revolution put the rotation: reported, but
        # a damaged commutator is named only where the comb shows the rotation (a wrong figure given would put
        # these lines elsewhere)
        out["rot1_rel"], out["rot2_rel"], out["fault_rel"] = rc.health(f, p_max, f_star / opts.ripples_per_rev, f_star,
                                                                       res, p, found, opts.min_snr)

    # 3. counting demodulated cycles
    xx, s0, nw = _window(bursts, k, fs)
    lo, hi = f_star / opts.band, min(f_star * opts.band, 0.45 * fs)
    sos = signal.butter(3, [lo, hi], btype="bandpass", fs=fs, output="sos")
    if len(xx) <= 3 * (2 * len(sos) + 1):  # sosfiltfilt's edge padding needs more samples than this
        out.update(key="few_cycles", f_Hz=f_star,
                   reason=f"{REASONS['few_cycles']} ({len(xx)} samples: too few to filter the line out and count it)")
        return out
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
    allowed = allowed_spread(cycles, snr, out["snr_wide"], opts)  # the quarters' own noise allowed for
    if spread > allowed or spread_i > opts.max_spread:  # the speed moved out of the fixed band: follow the line
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
    out["spread_allowed"] = allowed
    if spread > allowed or spread_i > opts.max_spread:
        from_i = (f"from the current, Ra dI / Ke, {spread_i:.1%}, {opts.max_spread:.1%} allowed"
                  if rpm_per_A is not None and np.isfinite(rpm_per_A) else "the current's share not read: no Ra or Ke")
        out.update(key="changing", reason=f"{REASONS['changing']} (quarters spread {spread:.1%}, {allowed:.1%} "
                   f"allowed with the count's noise; {from_i})")
        return out
    # the counted line, too, off the PWM and mains lines (beside a mains line: the count within MAINS_AGREE_REL of the fit)
    fixed = sync.fixed_line(bursts, k, f_count, res, line_placed(f_count), x0)
    if fixed:
        out.update(key=fixed[0], reason=fixed[1])
        return out
    out["confidence"] = float(min(1.0, (1 - math.exp(-snr / (4 * opts.min_snr)))
                                  * (1 - max(spread / allowed, spread_i / opts.max_spread) / 2)))
    return out


def estimate(bursts, duty, rpm_prior, opts: Options, prior_sd=None, rpm_per_A=None, unplaced_hum=True,
             turning_given=False):
    """Every window of a recording (a pandas DataFrame, one row per burst; see estimate_window).
    duty, rpm_prior: per window (None or NaN where unknown); prior_sd: the prior's voltage-borne
    sd per window (RPM), one figure or (below, above) (m2_prior_sd_rpm; None: 0, Ke's relative
    error opts.prior_rel_sd alone). The prior passes a running median of three windows first (the first
    and last windows: with their two neighbours), so that a glitch of one sample of V or I cannot steer the line; where the window's own prior and that median disagree (a step of speed beside a
    glitch, where the median takes the speed before the step), the window's speed may be either,
    and the prior's sd spans both: sd = sqrt(sd^2 + (own - median)^2). The DataFrame carries
    the prior used (`rpm_prior_used`), its sd (`prior_sd_below`, `prior_sd_above`) and the glitch's part of
    it (`prior_glitch`, |own - median|). rpm_per_A:
    Ra / Ke in RPM per A (rpm_per_amp), for the speed change the current shows inside a window. unplaced_hum,
    turning_given: estimate_window's."""
    import pandas as pd

    n = len(bursts)
    sd = np.zeros((n, 2))
    glitch = np.zeros(n)  # the sd's part that allows for a glitch beside the window (estimate_window's prior_glitch)
    if prior_sd is not None:  # one figure per window, or (below, above)
        given = np.asarray(prior_sd, float)
        given = np.repeat(given[:, None], 2, axis=1) if given.ndim == 1 else given
        sd = np.where(np.isfinite(given), given, 0.0)
    if rpm_prior is not None:  # a one-window glitch of V or I must not move the prior: median of three
        own = np.asarray(rpm_prior, float)
        pr = own
        if len(pr) >= 3:
            # the first and last windows with their two neighbours on one side (a glitch of V in a recording's last
            # row put the prior 55 % high there and its count on the line's second harmonic, +100 %, confident)
            pr = np.concatenate([np.median(pr[:3], keepdims=True),
                                 np.median(np.stack([pr[:-2], pr[1:-1], pr[2:]]), axis=0),
                                 np.median(pr[-3:], keepdims=True)])
            gap = np.nan_to_num(np.abs(own - pr), nan=0.0)
            sd = np.hypot(sd, gap[:, None])
            glitch = gap
        rpm_prior = pr
    rows = []
    for k in range(n):
        d = None if duty is None else float(duty[k])
        pr = None if rpm_prior is None else float(rpm_prior[k])
        before = None if rpm_prior is None or k == 0 else float(rpm_prior[k - 1])
        rows.append(estimate_window(bursts, k, d, pr, opts, before, sd[k], rpm_per_A, glitch[k], unplaced_hum,
                                    turning_given))
    df = pd.DataFrame(rows)
    df.insert(0, "seq", bursts.seq)
    df["confident"] = df["key"] == ""
    df["rpm_prior_used"] = np.nan if rpm_prior is None else rpm_prior
    df["prior_sd_below"] = sd[:, 0] if rpm_prior is not None else np.nan
    df["prior_sd_above"] = sd[:, 1] if rpm_prior is not None else np.nan
    df["prior_glitch"] = glitch if rpm_prior is not None else np.nan
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
    glitch = est["prior_glitch"].to_numpy(float) if "prior_glitch" in est else np.zeros(len(est))
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
            r = estimate_window(tail, 0, d, float(prior[k]), opts, None, sd[k], rpm_per_A, glitch[k])
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
