"""The ripple line's identity from the data (docs/ripple-line.md, "How the line is found"): the
lines of a window's current spectrum, the comb of the rotation frequency they form, the
multiple of it the commutation line sits at, and the rival lines around the back-EMF prior.

Physics: a rotor that is not perfectly symmetric (unequal coils, eccentricity, a brush that sits
off its axis, a worn bar) modulates the current once per revolution, so the spectrum holds lines
at multiples m f_rot of the motor's rotation frequency f_rot, the commutation line (at
ripples_per_rev x f_rot) among them. The comb's spacing gives f_rot from the data alone; the
line the user's ripples per revolution names must be the strongest line of the comb, at its
third multiple or above (the first two are the commutator's health lines: an eccentric rotor, a
bar with a raised contact resistance). Where it is not, the data show another multiple, and the
window says which, never confident.

Lines at multiples of the mains (MAINS_HZ, or the one the burst file declares: mains_of) are not rotation
lines: left out of the comb. A line
the acquisition puts there (a free-running PWM) is another's: `fixed_hz` takes those frequencies
(the hook for the PWM/mains check of the burst's sampling).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

MAINS_HZ = (50.0, 60.0)  # mains frequencies: their multiples (rectified mains, hum) are never rotation lines
#: the first multiple of the rotation frequency that may be the commutation line; the first and the second
#: are the commutator's health lines (commutator_health)
COMMUTATION_MIN_MULTIPLE = 3
MAX_MULTIPLE = 256      # the comb's multiples searched: up to 128 bars with 2 brushes
COMB_MIN_LINES = 2      # lines of the comb under the commutation line needed to call the spacing f_rot
COMB_REL_TOL = 0.004    # a line on the comb: within this share of its frequency (a speed steady to 0.4 %) ...
COMB_RES_TOL = 0.35     # ... plus this share of the spectrum's resolution (1 / window) of a multiple of f_rot
#: the comb's spacing explains at least this share of the evidence the best spacing explains: a line at the
#: threshold (noise now and then) weighs near nothing, a resolved rotation line several times more
COMB_EXPLAINED = 0.95
COMB_LINE_SNR = math.e  # a comb line stands e times over the line threshold (log(snr / min_snr) >= 1): noise,
#                         which reaches the threshold now and then, does not reach this in a window's spectrum
COMB_SPAN = 2.2         # the comb's lines: up to the commutation line's second harmonic
#: the commutator's health (health(), damaged(); docs/ripple-line.md step 5). A bar fault (a segment with a raised
#: contact resistance, a shorted coil, a burnt bar) changes the current over that segment's arc, once or twice a
#: revolution: a pattern with edges at the commutation instants, whose power spreads over many rotation harmonics,
#: up to and beyond the commutation line. A smooth modulation (an eccentric rotor, magnets or coils a little unequal)
#: puts lines at the first few multiples of the rotation only. So the fault's lines are read between the
#: commutation line and its second harmonic (k f_rot, N < k <= COMB_SPAN N, k not a multiple of N), where no smooth
#: modulation reaches: their summed power relative to the commutation line's (fault_rel) over HEALTH_FAULT_MAX, in
#: HEALTH_FAULT_MIN_LINES lines or more (a fault spreads its power; one line there may be chance or another's),
#: names a damaged commutator. Set on the twin (its bar fault, one segment +30 % of the loop resistance: 0.0087 at
#: 5 % on the load run; healthy windows 0.0062 at the most) and an independent capture simulator's bar faults
#: (0.068 and over; healthy, eccentric and asymmetric rotors 0.0018 at the most): hpddo.studies.ripple_line
HEALTH_FAULT_MAX = 0.007
HEALTH_FAULT_MIN_LINES = 2
#: ... and the line at twice the rotation frequency: with two brushes a segment passes under a brush twice a
#: revolution, so a bar with a raised contact resistance (or a shorted coil) shows at 2 f_rot and its multiples. Set
#: on the twin, between the healthy windows' largest and a worn segment's (+10 % of the loop resistance) smallest
#: (hpddo.studies.ripple_line, docs/figures/ripple_line.json: each case's percentiles)
HEALTH_ROT2_MAX = 0.012
#: ... but the line does not tell a worn bar from coils a few % unequal, as a healthy motor's are, nor from a smooth
#: modulation twice a revolution (an eccentric or asymmetric rotor, a load that pulses twice a turn), whatever its size:
#: on the independent commutator simulation (studies/commutator.py, coils' resistance and EMF 1-3 % sd apart, no fault)
#: the synchronous benches' comb windows read 0.005-0.056, over the twin's worn segment (+10 % of the loop resistance:
#: 0.007 at 1 %, 0.028 median); a capture simulator's healthy rotor modulated smoothly twice a revolution at 15-22 % of
#: the line's amplitude read 0.03-0.073, over the twin's damaged segment's 1st percentile (0.065). So a window over
#: HEALTH_ROT2_MAX is `damaged` all the same (not counted: the twin's worn segment's even lines make the comb's spacing
#: 2 f_rot, and its windows said "3 per revolution" wherever this line alone was let through: docs/ripple-line.md
#: step 5), but said to be uneven (uneven_only) unless a fault's own lines (fault_rel: edges at the commutation
#: instants) or the once-per-revolution line say more
#: the once-per-revolution line (eccentricity, a bent shaft, one brush's contact) is common in healthy motors:
#: named only where it is as strong as the commutation line (healthy twin windows: 0.026 at the most)
HEALTH_ROT1_MAX = 1.0
FIXED_REL_TOL = 0.001  # the mains' frequency holds within 0.1 % (50 +- 0.05 Hz)
LINE_FLOOR_OCTAVE = 1.5  # a line's noise floor: the median power from f / 1.5 to 1.5 f
#: a peak this many resolutions from a stronger line is its leakage (the Hann window's side lobes, -31 dB at
#: 2.5 resolutions, a line smeared by a speed that moves inside the window) unless LEAKAGE_SHARE of its power
LEAKAGE_RES = 4.0
LEAKAGE_SHARE = 0.01
#: ... and further out, up to LEAKAGE_FAR_RES resolutions, LEAKAGE_FAR_SHARE of it (the side lobes fall ~18 dB an
#: octave; a line 70 dB over the noise still leaks above it 4-10 resolutions away)
LEAKAGE_FAR_RES = 10.0
LEAKAGE_FAR_SHARE = 1e-4


@dataclasses.dataclass(frozen=True)
class Line:
    hz: float
    power: float
    snr: float


@dataclasses.dataclass(frozen=True)
class Comb:
    """The rotation comb of one window: f_rot (Hz, motor), the lines on it with their multiples,
    the strongest line from COMMUTATION_MIN_MULTIPLE on (the commutation line the data show) and
    its multiple."""

    rot_hz: float
    lines: tuple      # (Line, multiple) on the comb
    commutation: Line
    multiple: int


def near_fixed(hz: float, fixed_hz, tol_hz: float) -> bool:
    for f0 in fixed_hz:
        if f0 > 0 and hz >= f0 - tol_hz:
            k = round(hz / f0)
            if k >= 1 and abs(hz - k * f0) <= tol_hz:
                return True
    return False


def lines(f, p, f_lo: float, f_hi: float, res_hz: float, min_snr: float) -> list:
    """The lines of a spectrum (f Hz, power p, zero-padded) from f_lo to f_hi: local maxima at least
    one resolution (res_hz) apart whose power is min_snr times the median power around them (from
    f / LINE_FLOOR_OCTAVE to f x LINE_FLOOR_OCTAVE), their frequency refined by a parabola through
    the log power of the three bins at the peak. Strongest first."""
    from scipy.signal import find_peaks

    step = float(f[1] - f[0])
    band = np.flatnonzero((f >= f_lo) & (f <= f_hi))
    if len(band) < 5:
        return []
    pk, _ = find_peaks(p[band], distance=max(1, int(round(res_hz / step))))
    pk = band[pk][np.argsort(-p[band[pk]])]  # strongest first
    out = []
    logp = np.log(np.maximum(p, 1e-300))
    for j in pk:
        hz = float(f[j])
        if any((abs(ln.hz - hz) < LEAKAGE_RES * res_hz and p[j] < LEAKAGE_SHARE * ln.power)
               or (abs(ln.hz - hz) < LEAKAGE_FAR_RES * res_hz and p[j] < LEAKAGE_FAR_SHARE * ln.power) for ln in out):
            continue
        # the band f / LINE_FLOOR_OCTAVE .. f x LINE_FLOOR_OCTAVE as a slice of the (ascending) grid
        band_p = p[np.searchsorted(f, hz / LINE_FLOOR_OCTAVE, "left"):
                   np.searchsorted(f, hz * LINE_FLOOR_OCTAVE, "right")]
        # under min_snr where fewer than half the band lie at or under p / min_snr (its median then lies above):
        # a count, where the median's partition would cost ten times as much, for most peaks (the noise's)
        if 2 * np.count_nonzero(band_p <= float(p[j]) / min_snr) < len(band_p):
            continue
        floor = float(np.median(band_p))
        snr = float(p[j]) / max(floor, 1e-300)
        if snr < min_snr:
            continue
        if 0 < j < len(p) - 1:
            a, b, c = logp[j - 1], logp[j], logp[j + 1]
            den = a - 2 * b + c
            if den < 0:
                hz += 0.5 * (a - c) / den * step
        out.append(Line(hz, float(p[j]), snr))
    return sorted(out, key=lambda ln: -ln.power)


def mains_of(bursts) -> tuple:
    """The mains frequencies whose hum may be in the bursts' current, Hz: 50 and 60 (MAINS_HZ) whether the file
    declares one or not (hum is in a current declared or not, and a declared frequency's own multiples are out of
    the lines already: without_fixed), none where the file declares mains_hz=0 (no mains near the motor: a
    battery, nothing mains-powered beside it). A motor on a battery turning at 50 rev/s puts every rotation line
    on a multiple of 50 Hz: undeclared, its comb is left out and no window confident without a prior."""
    return () if getattr(bursts, "mains_hz", math.nan) == 0 else MAINS_HZ


def on_mains(hz: float, res_hz: float, mains=MAINS_HZ) -> bool:
    """Whether hz lies on a multiple of one of mains (mains_of: 50 or 60 Hz, or none), within fixed_tol_hz: hum may
    be there, declared or not."""
    return near_fixed(hz, tuple(mains), fixed_tol_hz(hz, res_hz))


def tol_hz(hz: float, res_hz: float) -> float:
    return COMB_REL_TOL * hz + COMB_RES_TOL * res_hz


def fixed_tol_hz(hz: float, res_hz: float) -> float:
    """How near a multiple of a fixed frequency (mains, PWM) a line must lie to be taken for it: half a
    resolution, and FIXED_REL_TOL of the line (the mains' own drift)."""
    return FIXED_REL_TOL * hz + 0.5 * res_hz


def _on_comb(found, g: float, res_hz: float):
    """The lines on the comb of spacing g: [(Line, multiple)]; one line a multiple (the strongest). A
    line is on it within its tolerance (_tol) and within 0.15 of a multiple of g, so that a narrow
    spacing does not collect lines by chance."""
    best = {}
    for ln in found:
        k = int(round(ln.hz / g))
        if 1 <= k <= MAX_MULTIPLE and abs(ln.hz - k * g) <= tol_hz(ln.hz, res_hz) and abs(ln.hz / g - k) <= 0.15:
            if k not in best or ln.power > best[k].power:
                best[k] = ln
    return sorted(((ln, k) for k, ln in best.items()), key=lambda t: t[1])


#: the PWM's sidebands left out of the comb (pwm_sidebands): h f_pwm +- j f_c for h up to MIX_PWM_HARMONICS, j up to
#: MIX_ORDERS. A free-running ADC sees the PWM's current ripple, whose amplitude the commutation modulates (the
#: inductance and the current change with the rotor's angle); its PWM-synchronous average removed, the modulation
#: stays as sidebands (f_pwm - f_c and f_pwm + f_c at a third to a half of the commutation line's power in the
#: independent commutator simulation), which a narrow spacing collects into a false comb
MIX_PWM_HARMONICS = 3
MIX_ORDERS = 2


def aliased_hz(hz: float, sample_hz: float) -> float:
    """Where a frequency lands in a spectrum sampled at sample_hz (0 to sample_hz / 2)."""
    return abs((hz + sample_hz / 2.0) % sample_hz - sample_hz / 2.0)


def pwm_sidebands(comm_hz: float, pwm_hz: float, sample_hz: float) -> list:
    """The PWM's sidebands around the commutation line comm_hz, aliased (MIX_PWM_HARMONICS, MIX_ORDERS): Hz
    with their order j (the line's frequency error enters j times)."""
    return [(aliased_hz(h * pwm_hz + sign * j * comm_hz, sample_hz), j)
            for h in range(1, MIX_PWM_HARMONICS + 1) for j in range(1, MIX_ORDERS + 1) for sign in (-1, 1)]


def rotation_comb(found, res_hz: float, min_snr: float, fixed_hz=(), pwm=None, mains=MAINS_HZ) -> Comb | None:
    """The rotation comb of a window's lines (lines()), or None where the lines do not form one.

    The commutation line is the strongest line of the comb (lines at multiples of the mains or of fixed_hz
    left out): the strongest lines are tried as it (_anchors), and the comb whose lines chance would least put there
    (_surprise) is the window's: a line of another origin stronger than the ripple (an undeclared PWM's) otherwise
    took the rotation lines of the ripple's comb onto a narrow comb of its own ("the ripple is 34 per revolution, not
    the 6 given": 187 of 210 windows with such a line in hpddo.studies.ripple_line's table of undeclared tones, 5 more
    counted on it, more than 5 % off). The rotation frequency is one of its sub-multiples f_c / m, m from
    COMMUTATION_MIN_MULTIPLE to MAX_MULTIPLE, no narrower than 2 resolutions (lines one spacing
    apart must be resolved). Each spacing explains the lines up to COMB_SPAN x f_c that lie within
    tolerance (COMB_REL_TOL, COMB_RES_TOL) of one of its multiples, each line weighing its evidence
    log(snr / min_snr), from COMB_LINE_SNR times the threshold on (noise reaches the threshold
    now and then); the comb is the widest spacing (the smallest m) that explains COMB_EXPLAINED of the most any
    spacing explains: a wider one
    leaves lines out, a narrower one (f_rot / 2) explains the same lines with more empty multiples.
    A comb needs at least COMB_MIN_LINES lines under the commutation line: a line and its
    harmonics alone show no rotation. pwm: (PWM Hz, sample Hz) of a free-running burst whose PWM lies in the
    band (pwm_of): the PWM's sidebands around the commutation line (pwm_sidebands) are no rotation lines. mains:
    the mains frequencies whose multiples are left out (mains_of)."""
    use = [ln for ln in found if not near_fixed(ln.hz, tuple(mains) + tuple(fixed_hz), fixed_tol_hz(ln.hz, res_hz))]
    if pwm is not None:  # nor a PWM sideband of one of the strongest lines, left out or not (a 6-ripple motor's line
        # at 60.8 Hz, left out as a 60 Hz multiple, put its sideband at 490.2 - 60.8 = 429.4 Hz at the head of the
        # rest, and the comb about that line named a healthy commutator damaged in 11 of a low-speed run's windows)
        strong = found[:COMB_ANCHORS]
        use = [ln for ln in use if not any(o.power > ln.power and _sideband_of(ln.hz, o.hz, res_hz, pwm)
                                           for o in strong)]
    if len(use) < COMB_MIN_LINES + 1:
        return None
    anchors = _anchors(use, res_hz) if pwm is None else use[:1]
    combs = [cb for cb in (_comb_about(c, use, res_hz, min_snr, pwm) for c in anchors) if cb is not None]
    if not combs:
        return None
    comb = max(combs, key=lambda sc: sc[0])[1]
    left = [ln for ln in found if ln not in use and ln.snr >= COMB_LINE_SNR * min_snr]
    if (_finer_left_out(comb, left, res_hz) or _sideband_of_hidden(comb, found, res_hz, pwm)
            or _stronger_left_on_comb(comb, left, res_hz, mains)):
        return None
    return comb


def _stronger_left_on_comb(comb: Comb, left, res_hz: float, mains=MAINS_HZ) -> bool:
    """Whether a line left out of the comb as a multiple of 50 or 60 Hz is stronger than the comb's commutation line and
    lies on the comb's grid (a multiple of f_rot from COMMUTATION_MIN_MULTIPLE on): the commutation line is the
    comb's strongest, so the left-out line may be the ripple itself, or hum on the grid by chance, and the comb cannot
    say which line is the commutation's. At 30 Hz of rotation every even multiple is one of 60 Hz: a 10-ripple motor
    at 1,800 RPM, its 300 Hz line left out, got a comb about its weak 11th rotation line, and the health lines
    against that line named a healthy commutator damaged (4 of 6 synthetic windows; a fuzzing round's damaged
    commutator at that speed went unnamed)."""
    for ln in left:
        if ln.power <= comb.commutation.power or not near_fixed(ln.hz, tuple(mains), fixed_tol_hz(ln.hz, res_hz)):
            continue
        k = int(round(ln.hz / comb.rot_hz))
        if k >= COMMUTATION_MIN_MULTIPLE and abs(ln.hz - k * comb.rot_hz) <= tol_hz(ln.hz, res_hz):
            return True
    return False


def _sideband_of_hidden(comb: Comb, found, res_hz: float, pwm) -> bool:
    """Whether the comb's commutation line may be a free-running PWM's sideband of a line that does not show: its
    mirror sideband shows (hidden_line_mirrors) about a line g in the band the count searches (up to the sample
    rate's half over COMB_SPAN) where no line lies. Then the comb rests on a line of the PWM's, and its spacing on
    lines that fall near its grid by chance: an independent probe's 18-ripple motor under a 976.6 Hz PWM sampled
    free at 9.6 kS/s, its commutation line at 600 Hz under the noise and its sidebands at 376.6 and 1576.6 Hz the
    strongest lines, made a comb about 376.6 Hz 8.36 Hz apart ("45 per revolution") that named the healthy
    commutator damaged. A true commutation line's own sideband f_pwm - f_c shows as a line of its own, so that g
    is no hidden line and its comb stands."""
    if pwm is None:
        return False
    top_hz = pwm[1] / 2.0 / COMB_SPAN
    return any(g <= top_hz and not any(abs(ln.hz - g) <= tol_hz(g, res_hz) for ln in found)
               for g, _ in hidden_line_mirrors(found, comb.commutation.hz, res_hz, pwm, lambda hz: True))


#: the finer spacings (f_rot / d) whose lines rotation_comb's mains rule may have left out (_finer_left_out)
FINER_DIVISORS = (2, 3)


def _finer_left_out(comb: Comb, left, res_hz: float) -> bool:
    """Whether a line left out of the comb (on a multiple of 50 or 60 Hz, or a PWM sideband) lies where a comb of a
    finer spacing f_rot / d would put its lines under the comb's first (k f_rot / d, k < d): the rotation may be
    that finer spacing, its own line left out, and the comb cannot say how many ripples a revolution holds. An
    independent probe's 14-ripple motor at 59.17 Hz had its once-per-revolution line left out as a 60 Hz multiple,
    and the comb of its even lines said "the ripple is 7 per revolution, not the 14 given" in 5 windows."""
    for d in FINER_DIVISORS:
        g = comb.rot_hz / d
        for ln in left:
            k = int(round(ln.hz / g))
            if 1 <= k < d and abs(ln.hz - k * g) <= tol_hz(ln.hz, res_hz):
                return True
    return False


#: the lines tried as the commutation line (rotation_comb), strongest first
COMB_ANCHORS = 3


def _anchors(use, res_hz: float) -> list:
    """The lines rotation_comb tries as the commutation line: the strongest of use (lines strongest first) and the
    next ones up to COMB_ANCHORS that are not its harmonics (a harmonic of the strongest line is the same line's: a
    quantised 80 Hz cosine's 17th harmonic made a comb of its intermodulation products, "59 per revolution"). Under a
    free-running PWM (rotation_comb's pwm) the strongest alone: the PWM's residue and its products with the ripple put
    lines on grids of their own (a 490 Hz PWM at 9.6 kS/s, a line at 448.4 Hz: "32 per revolution" in 23 windows of
    a low-speed run that showed no comb before, and every window of the run demoted)."""
    top = use[0]

    def harmonic(ln) -> bool:
        k = round(ln.hz / top.hz)
        return k >= 2 and abs(ln.hz - k * top.hz) <= k * tol_hz(top.hz, res_hz)

    return [top] + [ln for ln in use[1:] if not harmonic(ln)][:COMB_ANCHORS - 1]


#: the precision of a line's frequency on a comb (_precision_hz): a share of the spectrum's resolution (a resolved
#: line's peak refined by a parabola through three bins) and of the line's frequency (a speed that drifts inside the
#: window moves every line's peak in proportion; a quarter of COMB_REL_TOL, the drift the comb's tolerance allows)
COMB_PRECISION_RES = 0.1
COMB_PRECISION_REL = COMB_REL_TOL / 4


def _precision_hz(hz: float, res_hz: float) -> float:
    return COMB_PRECISION_RES * res_hz + COMB_PRECISION_REL * hz


def _spacing(on, weights) -> float:
    """The least-squares spacing g of a comb's lines (on: (Line, multiple)), each line at multiple k weighed by
    weights: hz = k g."""
    w = np.asarray(weights, float)
    k = np.array([j for _, j in on], float)
    hz = np.array([ln.hz for ln, _ in on])
    return float(np.sum(w * k * hz) / np.sum(w * k * k))


def _line_evidence(on, m: int, res_hz: float) -> list:
    """Per line of a candidate comb (lines on it with their multiples, the commutation line at m), how much more
    likely the line lies where it does if it is on the comb than if it lies anywhere: log(g / (s sqrt(2 pi))) -
    d^2 / (2 s^2), d its distance from its multiple of the spacing g the lines fit (least squares, each weighed by
    1 / s^2), s its precision (_precision_hz). The tolerance that lets a line on the comb (tol_hz) allows a drift
    of the speed; lines of one comb drift together, so a line of another origin that the tolerance lets on lies
    further from the others' fit than their precision (an undeclared tone's harmonic 4.7 Hz off the 23rd multiple of
    52.57 Hz, within tol_hz's 5.6 Hz, where the rotation lines lie within 0.05 Hz of theirs)."""
    w = [1.0 / _precision_hz(ln.hz, res_hz) ** 2 for ln, _ in on]
    g = _spacing(on, w)
    s = [1.0 / math.sqrt(wi) for wi in w]
    return [math.log(g / (si * math.sqrt(2 * math.pi))) - (ln.hz - k * g) ** 2 / (2 * si * si)
            for (ln, k), si in zip(on, s)]


def _surprise(on, m: int, res_hz: float) -> float:
    """How unlikely by chance a comb's lines lie where they do: _line_evidence summed over its lines but the
    commutation line's harmonics (which lie on the comb of whatever line is taken for it)."""
    return sum(e for e, (_, k) in zip(_line_evidence(on, m, res_hz), on) if k == m or k % m)


def _comb_about(c, use, res_hz: float, min_snr: float, pwm):
    """(surprise, Comb) of the rotation comb whose commutation line is c (rotation_comb), or None: no spacing holds
    COMB_MIN_LINES lines under it, or a line of the comb stronger than c (from COMMUTATION_MIN_MULTIPLE on where c
    is the strongest of use, the lines of the window, strongest first; else any): c would not be the comb's
    commutation line."""
    strongest = use[0]
    use = [ln for ln in use if ln.hz <= COMB_SPAN * c.hz and (ln is c or ln.snr >= COMB_LINE_SNR * min_snr)]
    if pwm is not None:
        use = [ln for ln in use if ln is c or not _sideband_of(ln.hz, c.hz, res_hz, pwm)]
    scored = []
    for m in range(COMMUTATION_MIN_MULTIPLE, MAX_MULTIPLE + 1):
        g = c.hz / m
        if g < 2.0 * res_hz:
            break
        on = _on_comb(use, g, res_hz)
        # c is the comb's commutation line only where no line on it from COMMUTATION_MIN_MULTIPLE on is stronger, and
        # a line tried after the strongest (not the window's strongest line) only where none at all is: its comb would
        # hold the strongest line as a health line (the twin's ripple at 51.7 Hz is the first multiple of 25.9 Hz
        # below its own harmonic at 103.5 Hz, a "damaged commutator" in every healthy window). A stronger line that
        # the tolerance lets on but that lies off the others' fit is no line of the comb.
        lowest = COMMUTATION_MIN_MULTIPLE if c is strongest else 1
        if any(k >= lowest and ln.power > c.power for ln, k in on):
            ev = _line_evidence(on, m, res_hz)
            if any(k >= lowest and ln.power > c.power and e > 0 for (ln, k), e in zip(on, ev)):
                continue
            on = [(ln, k) for (ln, k), e in zip(on, ev) if not (ln.power > c.power and e <= 0)]
        # the other lines' multiples share a factor the commutation line's does not: they are a comb of that many
        # times the spacing, and the commutation line is not on it (a 6-ripple motor's 1, 2 and 3 f_rot at 175 Hz
        # fell on 5, 10 and 15 x 34.88 Hz, a tone's 28th sub-multiple: "the ripple is 28 per revolution")
        others = [k for _, k in on if k % m]  # (not the commutation line, nor its harmonics)
        d = math.gcd(*others) if others else 1
        if d > 1 and m % d:
            continue
        if sum(1 for _, k in on if k < m) >= COMB_MIN_LINES:
            scored.append((sum(math.log(ln.snr / min_snr) for ln, _ in on), m, on))
    if not scored:
        return None
    _, m, on = _widest_explaining(scored, c.hz, res_hz)
    if _by_chance(on, m, c.hz, res_hz):
        return None
    # f_rot refined: the least-squares spacing of the lines on the comb, weighted by their power
    return _surprise(on, m, res_hz), Comb(_spacing(on, [ln.power for ln, _ in on]), tuple(on), c, int(m))


#: a narrower spacing takes a wider one's place (_widest_explaining) only where the lines it adds under the commutation
#: line would lie that near its multiples by chance with at most this probability
COMB_CHANCE = 0.1


def _chance(lines_k, g: float, res_hz: float) -> float:
    """The chance that lines (Line, multiple) lie within tol_hz of a multiple of the spacing g wherever they sit:
    each 2 tol_hz / g."""
    chance = 1.0
    for ln, _ in lines_k:
        chance *= min(1.0, 2.0 * tol_hz(ln.hz, res_hz) / g)
    return chance


def _by_chance(on, m: int, comm_hz: float, res_hz: float) -> bool:
    """Whether a comb's lines under its commutation line (not its harmonics) lie near the multiples of its spacing
    comm_hz / m as any lines would by chance, over every spacing tried up to it (from COMMUTATION_MIN_MULTIPLE on):
    the chance of one of them holding its lines (_chance, times the spacings tried) over COMB_CHANCE. The widest
    spacing that holds COMB_MIN_LINES lines is otherwise taken whatever its chance: an independent probe's
    free-running capture, its rotation lines on the 50 Hz mains' multiples and left out, took two of the PWM's
    intermodulation lines for the 13th and 29th multiples of 11.75 Hz ("the ripple is 60 per revolution, not the
    14 given", chance 0.08 each time, 58 spacings tried), and such windows outvoted those whose comb showed 14."""
    under = [(ln, k) for ln, k in on if k < m]
    return _chance(under, comm_hz / m, res_hz) * (m - COMMUTATION_MIN_MULTIPLE + 1) > COMB_CHANCE


def _widest_explaining(scored, comm_hz: float, res_hz: float):
    """Of rotation_comb's candidate spacings (evidence explained, m, lines on the comb; the spacing comm_hz / m), the
    widest (smallest m) that explains COMB_EXPLAINED of what any narrower one explains; a narrower one takes its
    place only with lines of its own under the commutation line that the wider comb does not hold and that would not
    lie so near its multiples by chance: each line within tol_hz of a multiple of a spacing g has the chance 2
    tol_hz / g of doing so wherever it sits, and the lines' chances together must be at most COMB_CHANCE. A narrow
    spacing holds any line near one of its multiples (at f_c / 54 half of all frequencies), so a line of another
    origin (an undeclared PWM's, a supply's) made a 6-ripple motor's comb of 1, 2 and 3 f_rot into "the ripple is 54
    per revolution" (66, 84 in the next windows); an 18-bar motor given 18 shows its once-per-revolution line
    (chance 0.07 at 23.7 Hz over half a second), a motor whose figure is twice the one given its odd rotation lines."""
    ordered = sorted(scored, key=lambda s: s[1])
    best = ordered[0]
    for cand in ordered[1:]:
        if best[0] >= COMB_EXPLAINED * cand[0]:
            continue
        held = {id(ln) for ln, _ in best[2]}
        chance = _chance([(ln, k) for ln, k in cand[2] if k < cand[1] and id(ln) not in held], comm_hz / cand[1],
                         res_hz)
        if chance <= COMB_CHANCE:
            best = cand
    return best


def fixed_hz_of(bursts) -> tuple:
    """The fixed lines the acquisition declares, Hz: the PWM frequency the burst file declares
    (`Bursts.pwm_hz`, read from its metadata by logs.ripple.of_meta: the one reading of it that the
    PWM-synchronous average also uses) where it lies inside the band the samples hold (under half
    the sample rate: sampled once per PWM period, the PWM aliases to 0 Hz and puts no line). Their
    multiples are left out of the comb; this is the hook where a check of the sampling (free-running
    PWM, mains) adds its own."""
    pwm = float(bursts.pwm_hz)
    return (pwm,) if math.isfinite(pwm) and 0 < pwm < bursts.sample_hz / 2 else ()


def pwm_of(bursts):
    """(PWM Hz, sample Hz) of bursts whose declared PWM lies inside the band the samples hold (free-running
    sampling: under half the sample rate), else None (rotation_comb's pwm)."""
    fixed = fixed_hz_of(bursts)
    return (fixed[0], float(bursts.sample_hz)) if fixed else None


# The PWM's harmonics whose aliases are left out of the comb: a PWM current's edges put harmonics
# falling as 1 / h^2 far above the 20 the confidence check names (sync.PWM_HARMONICS), and on
# a current cleaned of its PWM-synchronous average the 39th of 490 Hz, aliased at 9.6 kS/s to 82.4 Hz,
# still stands at 2.6 % of the commutation line's power, beside it.
COMB_PWM_HARMONICS = 100


def without_fixed(found, bursts, res_hz: float) -> list:
    """found (lines()) without the lines the burst file's declared supply puts there: the PWM's
    harmonics up to COMB_PWM_HARMONICS where they alias into the band, the declared mains' multiples;
    the strongest line is kept whatever it sits on (the confidence check, sync.fixed_line,
    judges it). No rotation line, no rival."""
    if not found:
        return []
    fs = bursts.sample_hz
    fixed = []
    pwm = getattr(bursts, "pwm_hz", float("nan"))
    if math.isfinite(pwm) and 0 < pwm < fs / 2.0:
        fixed += [abs((h * pwm + fs / 2.0) % fs - fs / 2.0) for h in range(1, COMB_PWM_HARMONICS + 1)]
    mains = getattr(bursts, "mains_hz", float("nan"))
    mains = mains if math.isfinite(mains) and mains > 0 else None

    def on_mains(hz: float) -> bool:
        """hz within the tolerance of a multiple of the mains frequency (1 to fs / 2: as many as there
        are, computed, not listed: a file may declare any positive mains frequency)."""
        top = math.floor(fs / 2.0 / mains)
        h = min(max(round(hz / mains), 1), top)  # the nearest multiple there is
        return top >= 1 and abs(hz - h * mains) <= fixed_tol_hz(hz, res_hz)

    if not fixed and mains is None:
        return list(found)
    top = max(found, key=lambda ln: ln.power)
    return [ln for ln in found if ln is top
            or not (any(abs(ln.hz - f) <= fixed_tol_hz(ln.hz, res_hz) for f in fixed)
                    or (mains is not None and on_mains(ln.hz)))]


def _power_at(found, f_hz: float, res_hz: float) -> float:
    """The power of the strongest line of found (lines()) within tol_hz of f_hz; 0 where there is none."""
    return max((ln.power for ln in found if abs(ln.hz - f_hz) <= tol_hz(f_hz, res_hz)), default=0.0)


def rivals(found, f_hz: float, res_hz: float, in_spread, share: float, exclude=()) -> list:
    """The lines that rival the chosen line at f_hz: every line (found, lines()) other than it and
    other than those in exclude (Hz: lines the comb has placed), whose frequency in_spread (a
    function of Hz -> bool: inside the back-EMF prior's spread) and whose power is at least share
    of the chosen line's. Strongest first."""
    p0 = _power_at(found, f_hz, res_hz)
    if p0 <= 0:
        return []
    out = []
    for ln in found:
        if abs(ln.hz - f_hz) <= tol_hz(f_hz, res_hz) or any(abs(ln.hz - e) <= tol_hz(e, res_hz) for e in exclude):
            continue
        if ln.power >= share * p0 and in_spread(ln.hz):
            out.append(ln)
    return out


def _sideband_tol(comm_hz: float, j: int, res_hz: float) -> float:
    """How near a PWM sideband of order j around a line at comm_hz a line must lie to be taken for it: tol_hz's
    form, the line's frequency error entering j times."""
    return COMB_REL_TOL * j * comm_hz + COMB_RES_TOL * res_hz


def _sideband_of(hz: float, comm_hz: float, res_hz: float, pwm) -> bool:
    """Whether a line at hz lies on one of the PWM's sidebands around a line at comm_hz (pwm_sidebands, the
    tolerance rotation_comb leaves them out with)."""
    return any(abs(hz - s) <= _sideband_tol(comm_hz, j, res_hz) for s, j in pwm_sidebands(comm_hz, *pwm))


#: unplaced_rivals takes a line on a multiple of 50 or 60 Hz that the window bears out as hum (hum_shows) only from
#: this share of the chosen line's power on: a little hum is in most currents (the twin's 50 Hz line at
#: 0.0006-0.005 of the ripple's power), and for it to hide the ripple the ripple would have to sit on a multiple of
#: the mains while another line is taken for it; from a hundredth on, it may be the ripple (one 7 % of the power of
#: an undeclared line beside it, at 900 Hz), and the window says to declare the mains where it is hum
MAINS_RIVAL_SHARE = 0.01


def hum_shows(found, line, res_hz: float, mains=MAINS_HZ) -> bool:
    """Whether the window bears a line on a multiple k of 50 or 60 Hz (mains: mains_of) out as hum: its order is the hum's
    first (k = 1, a stray field's line; k = 2, a rectified supply's), or a line at a lower multiple of the same mains
    frequency stands at least as strong (hum's lines fall with their order: a rectified supply's as 3 / (4 k^2 - 1)).
    A line on a high multiple standing over every lower one is not shown to be hum, and may be a ripple that sits
    there (360 Hz, at a hundredth of the power of an undeclared line beside it, was left out for hum and the other
    line counted, confidently and more than 5 % off)."""
    tol = fixed_tol_hz(line.hz, res_hz)
    for f0 in mains:
        k = round(line.hz / f0)
        if k < 1 or abs(line.hz - k * f0) > tol:
            continue
        if k <= 2 or any(ln.power >= line.power and abs(ln.hz - j * f0) <= fixed_tol_hz(j * f0, res_hz)
                         for ln in found for j in range(1, k)):
            return True
    return False


def unplaced_rivals(found, f_hz: float, res_hz: float, in_spread, min_snr: float, family=(), mains=MAINS_HZ) -> list:
    """Where no comb places the chosen line at f_hz, the other lines that could be the ripple as well: every line of
    found (lines()) standing COMB_LINE_SNR times over the line threshold (a resolved line: noise does not reach it),
    inside the back-EMF prior's spread (in_spread: Hz -> bool), whatever its power, but the chosen line's own family
    (at the ratios `family` to it: count.estimate_window gives line.ALTERNATIVES, which its family check weighs).
    Without a comb the line's identity rests on the prior alone, and power does not name the ripple: an undeclared
    PWM or a supply's line, 14x the ripple's power and inside the prior's spread, was counted as the ripple of 12
    comb-less windows, 5 of them 5-8 % off, confidently. A line on a multiple of 50 or 60 Hz is a rival
    from MAINS_RIVAL_SHARE of the chosen line's power on (undeclared, hum is not known to be there, and a ripple may
    sit on such a multiple: 900 and 1050 Hz, in that test), and under it too where the window does not bear it out
    as hum (hum_shows); the declared mains' multiples are out of found already (without_fixed). Strongest first."""
    # the family about the chosen line's own peak (f_hz is the prior-weighted search's, up to half a resolution off
    # it), its error entering r times at r f
    near = [ln for ln in found if abs(ln.hz - f_hz) <= tol_hz(f_hz, res_hz)]
    f_line = min(near, key=lambda ln: abs(ln.hz - f_hz)).hz if near else f_hz
    p0 = _power_at(found, f_hz, res_hz)
    out = []
    for ln in found:
        if ln.snr < COMB_LINE_SNR * min_snr:
            continue
        if any(abs(ln.hz - r * f_line) <= max(r, 1.0) * tol_hz(f_line, res_hz) for r in family):
            continue
        if on_mains(ln.hz, res_hz, mains) and ln.power < MAINS_RIVAL_SHARE * p0 and hum_shows(found, ln, res_hz, mains):
            continue
        out.append(ln)
    return rivals(out, f_hz, res_hz, in_spread, 0.0)


#: a line and its PWM sideband partner (sideband_partners) rival each other from this share of the chosen line's
#: power on: 0, any partner the spectrum shows (a line of lines(), over its noise). The sideband's depth is the
#: PWM ripple's modulation by the rotor, which no motor bounds: at a tenth (the rule before) a sideband 10x the
#: line's power, the line under a tenth of it, was taken for the line, confidently and 21 % off
SIDEBAND_SHARE = 0.0


def sideband_partners(found, f_hz: float, res_hz: float, pwm, in_spread, share: float = SIDEBAND_SHARE) -> list:
    """The lines that make a pair with the chosen line at f_hz under a free-running PWM (pwm: pwm_of's
    (PWM Hz, sample Hz)): each a PWM sideband of the other (pwm_sidebands, either way round: f_pwm - f_c
    and f_c are each other's), inside the back-EMF prior's spread (in_spread: Hz -> bool), with at least
    `share` of the chosen line's power. Which of the two is the commutation line and which its sideband,
    the half-power rule of rivals cannot say: the sideband's depth is the PWM current ripple's modulation
    by the rotor, a third to a half of the line's power in the independent commutator simulation, and
    stronger than the line where the PWM ripple outgrows the commutation's (a hobby driver at 490 Hz);
    the sidebands around either line are the same set of frequencies, and either may be the stronger by any
    factor. Strongest first; none where pwm is None."""
    if pwm is None:
        return []
    p0 = _power_at(found, f_hz, res_hz)
    out = []
    for ln in found:
        if abs(ln.hz - f_hz) <= tol_hz(f_hz, res_hz) or ln.power < share * p0 or not in_spread(ln.hz):
            continue
        if _sideband_of(f_hz, ln.hz, res_hz, pwm) or _sideband_of(ln.hz, f_hz, res_hz, pwm):
            out.append(ln)
    return sorted(out, key=lambda ln: -ln.power)


#: a chosen line's mirror sideband (hidden_line_mirrors) counts from this share of the chosen line's power on: a
#: line's two sidebands h f_pwm -+ j f_c carry about the same power (the PWM ripple's modulation by the rotor)
MIRROR_SHARE = 0.1


def hidden_line_mirrors(found, f_hz: float, res_hz: float, pwm, in_spread, share: float = MIRROR_SHARE) -> list:
    """Where the chosen line at f_hz may be a free-running PWM's sideband of a commutation line hidden under the
    spectrum's noise: each (hidden line's Hz, mirror line) for a line g inside the prior's spread (in_spread) of
    which f_hz is a sideband (h f_pwm + s j g, aliased: pwm_sidebands' orders) while the other sideband of the
    same order (h f_pwm - s j g, aliased) shows with at least `share` of the chosen line's power. A line's
    sidebands come in pairs of about equal power, a line with no sidebands has neither, so a window whose only
    line in the spread has such a mirror cannot say whether it is the commutation line or a sideband of one too
    weak to see (a light load's small current under a 490 Hz hobby driver). The partner rule (sideband_partners)
    sees g where it shows; this one where it does not. None where pwm is None."""
    if pwm is None:
        return []
    pwm_hz, sample_hz = pwm
    p0 = _power_at(found, f_hz, res_hz)
    out = []
    for h in range(1, MIX_PWM_HARMONICS + 1):
        for j in range(1, MIX_ORDERS + 1):
            for sign in (-1, 1):
                for k in (-1, 0, 1):  # f_hz = |h f_pwm + sign j g - k fs| (aliased), for g
                    for flip in (-1, 1):
                        g = (flip * f_hz + k * sample_hz - h * pwm_hz) / (sign * j)
                        tol = _sideband_tol(g, j, res_hz)
                        if not g > 0 or abs(g - f_hz) <= tol_hz(f_hz, res_hz) or not in_spread(g):
                            continue
                        if abs(aliased_hz(h * pwm_hz + sign * j * g, sample_hz) - f_hz) > tol:
                            continue
                        m = aliased_hz(h * pwm_hz - sign * j * g, sample_hz)
                        near = [ln for ln in found if abs(ln.hz - m) <= tol and abs(ln.hz - f_hz) > tol
                                and ln.power >= share * p0]
                        out += [(g, ln) for ln in near]
    return sorted(out, key=lambda gl: -gl[1].power)


#: a line whose power stays within 6 dB of its peak over more than this many resolutions is smeared: the speed
#: moved inside the window (a steady line under the Hann window spans 2; an independent probe's ramp, 4 % of the
#: speed in a window, 22-28)
SMEAR_RES = 3.0


def line_width_res(f, p, hz: float, res_hz: float) -> float:
    """The width, in resolutions, over which the line nearest hz (its peak within a resolution, p the spectrum's
    power on the grid f) stays at a quarter of its peak power or more."""
    step = float(f[1] - f[0])
    w = max(1, int(round(res_hz / step)))
    j = int(np.argmin(np.abs(f - hz)))
    lo, hi = max(0, j - w), min(len(p), j + w + 1)
    j = lo + int(np.argmax(p[lo:hi]))
    above = p >= p[j] / 4.0
    left = j - (np.argmin(above[j::-1]) if not above[j::-1].all() else j)
    right = j + (np.argmin(above[j:]) if not above[j:].all() else len(p) - 1 - j)
    return float(f[min(right, len(p) - 1)] - f[max(left, 0)]) / res_hz


def health(f, p_max, rot_hz: float, comm_hz: float, res_hz: float, p=None, found=None, min_snr: float = 10.0) -> tuple:
    """The commutator's health lines of one window: the power at once and twice the rotation
    frequency (the strongest bin within half a resolution, p_max) relative to the commutation
    line's, and the fault's lines (fault_rel: the lines of found, resolved (COMB_LINE_SNR times min_snr, the line
    threshold), on the rotation's multiples between the
    commutation line and its second harmonic, off its multiples, summed, relative to it; 0 with fewer than
    HEALTH_FAULT_MIN_LINES of them; NaN without found). An eccentric rotor and a worn or damaged bar raise the first
    two; a bar fault alone the third (HEALTH_FAULT_MAX). NaN where the
    rotation frequency is under 2 resolutions (res_hz): its line is not resolved from the
    spectrum's lowest bins; and, given the spectrum p, where the commutation line is smeared (SMEAR_RES): the
    speed moved inside the window, which spreads the commutation line's power N times as wide as the rotation
    line's, and their peaks do not compare (an independent probe's healthy 18-ripple motor on a ramp, 4 % of its
    speed in each window, was named damaged in 9 of 16 windows)."""
    pc = float(np.interp(comm_hz, f, p_max))
    if not (pc > 0 and rot_hz >= 2.0 * res_hz):
        return math.nan, math.nan, math.nan
    if p is not None and line_width_res(f, p, comm_hz, res_hz) > SMEAR_RES:
        return math.nan, math.nan, math.nan
    return (float(np.interp(rot_hz, f, p_max)) / pc, float(np.interp(2 * rot_hz, f, p_max)) / pc,
            fault_rel(found, rot_hz, comm_hz, res_hz, pc, min_snr) if found is not None else math.nan)


def fault_rel(found, rot_hz: float, comm_hz: float, res_hz: float, comm_power: float, min_snr: float) -> float:
    """The power of the lines of found that stand COMB_LINE_SNR times over min_snr (as a comb's lines: noise reaches
    the threshold now and then, and two such near the multiples named a synthetic healthy motor damaged in 7 of 468
    windows; hpddo.studies.ripple_line.run_tones) (strongest within a comb's tolerance of each multiple) at k rot_hz,
    N < k <= COMB_SPAN N and k not a multiple of N (N = comm_hz / rot_hz), summed and relative to comm_power; 0
    where fewer than HEALTH_FAULT_MIN_LINES lines lie there."""
    n = max(1, int(round(comm_hz / rot_hz)))
    powers = []
    for k in range(n + 1, int(COMB_SPAN * n) + 1):
        if k % n:
            hz = k * rot_hz
            near = [ln.power for ln in found
                    if abs(ln.hz - hz) <= tol_hz(hz, res_hz) and ln.snr >= COMB_LINE_SNR * min_snr]
            if near:
                powers.append(max(near))
    return float(sum(powers) / comm_power) if len(powers) >= HEALTH_FAULT_MIN_LINES else 0.0


def damaged(rot1_rel: float, rot2_rel: float, fault: float = math.nan) -> bool:
    """Whether a window's health lines (health()) name a damaged commutator: any over its threshold
    (HEALTH_ROT1_MAX, HEALTH_ROT2_MAX, HEALTH_FAULT_MAX)."""
    return bool((np.isfinite(rot1_rel) and rot1_rel > HEALTH_ROT1_MAX)
                or (np.isfinite(rot2_rel) and rot2_rel > HEALTH_ROT2_MAX)
                or (np.isfinite(fault) and fault > HEALTH_FAULT_MAX))


def uneven_only(rot1_rel: float, rot2_rel: float, fault: float = math.nan) -> bool:
    """Whether health lines over the threshold (damaged) are only what a worn bar, coils a few % unequal and a smooth
    modulation twice a revolution all make: the line at twice the rotation frequency read, the once-per-revolution
    line within its bound, and no fault's lines over theirs (what tells a fault from a smooth modulation is where its
    lines lie, not how strong the line twice a revolution is)."""
    return not (np.isfinite(rot1_rel) and rot1_rel > HEALTH_ROT1_MAX) and np.isfinite(rot2_rel) \
        and not (np.isfinite(fault) and fault > HEALTH_FAULT_MAX)


UNEVEN = ("an uneven commutator: the line at twice the rotation frequency is strong against the commutation line, "
          "as a worn bar makes it and as coils a few % unequal or a smooth modulation twice a revolution do in a "
          "healthy motor (this line does not tell them apart); the ripple is not counted through it")


def damaged_reason(head: str, rot1_rel: float, rot2_rel: float, fault: float, rot_hz: float) -> str:
    """The reason of a window named damaged: head, or UNEVEN where the lines stay below what tells a fault
    (uneven_only), with the lines' powers and the thresholds."""
    return (f"{UNEVEN if uneven_only(rot1_rel, rot2_rel, fault) else head} (at {rot_hz:.2f} and {2 * rot_hz:.2f} Hz "
            f"{rot1_rel:.3g} and {rot2_rel:.3g} of its power, over {HEALTH_ROT1_MAX:g} and {HEALTH_ROT2_MAX:g}; the "
            f"fault's lines between it and its second harmonic {fault:.3g}, over {HEALTH_FAULT_MAX:g})")
