"""The ripples per motor revolution from the data (hpddo ripple --calibrate, docs/ripple.md): the
comb of rotation lines each window shows (comb.py), and the strongest line against an encoder
or tachometer where the log has one; and Ke of the back-EMF prior from the ripple where the user
gives none (`calibrate_ke`)."""
from __future__ import annotations

import math

import numpy as np

from . import comb as rc
from . import sync
from .count import estimate
from .line import CALIBRATE_AGREE, CALIBRATE_MIN_WINDOWS, spectrum
from .options import Options


def window_comb(bursts, k: int, opts):
    """The lines and the rotation comb of window k's current (comb.lines, rotation_comb; the
    comb None where the lines form none), the spectrum's resolution (Hz), and whether the comb's
    health lines name a damaged commutator (comb.health, damaged). opts: options.Options."""
    from scipy.ndimage import maximum_filter1d

    fs = bursts.sample_hz
    x = bursts.current_A(k)
    res = fs / len(x)
    f, p = spectrum(x, fs)
    found = rc.lines(f, p, max(2.0 * res, 0.5), fs / 2.0 / 2.2, res, opts.min_snr)
    found = rc.without_fixed(found, bursts, res)
    comb = rc.rotation_comb(found, res, opts.min_snr, rc.fixed_hz_of(bursts), rc.pwm_of(bursts), rc.mains_of(bursts))
    bad = ""
    if comb is not None:
        p_max = maximum_filter1d(p, size=max(1, int(round(res / (f[1] - f[0])))) | 1)
        lines = rc.health(f, p_max, comb.rot_hz, comb.commutation.hz, res, p, found, opts.min_snr)
        if rc.damaged(*lines):
            bad = "uneven" if rc.uneven_only(*lines) else "damaged"
    return found, comb, res, bad


def _health_word(damaged: int, uneven: int) -> str:
    """What the `damaged` windows left out of the comb are called, `uneven` of them only for the line twice a
    revolution (comb.uneven_only), which a healthy motor's may be too."""
    return ("uneven or damaged" if uneven < damaged else "uneven") if uneven else "damaged"


def _health_lines(damaged: int, uneven: int) -> str:
    """The statement's words on those windows' lines (_health_word, and why an uneven one is no fault named)."""
    word = _health_word(damaged, uneven)
    if not uneven:
        return f"a {word} commutator's lines"
    why = "a worn bar, coils a few % unequal or a smooth modulation twice a revolution, which that line does not tell apart"
    return f"an {word} commutator's lines ({f'{uneven} uneven: ' if uneven < damaged else ''}{why})"


#: calibrate with an encoder: a window's line within this share of a whole number of ripples per revolution
CALIBRATE_WHOLE = 0.03


def encoder_lines(found, bursts, res: float) -> list:
    """The lines of a window (strongest first) that may be the commutation line against an encoder: not on a
    multiple of a declared PWM, nor on a multiple of 50 or 60 Hz that the window bears out as hum (comb.hum_shows;
    a declared mains' are out already, comb.without_fixed). A line on a mains multiple that nothing shows to be hum is
    kept: a healthy 18-ripple motor at 5000 RPM puts its ripple on 1500 Hz, and the next line, the rotation's own,
    named "1 per revolution"."""
    fixed, mains = rc.fixed_hz_of(bursts), rc.mains_of(bursts)
    return [ln for ln in found if not rc.near_fixed(ln.hz, fixed, rc.fixed_tol_hz(ln.hz, res))
            and not (rc.on_mains(ln.hz, res, mains) and rc.hum_shows(found, ln, res, mains))]


def calibrate(bursts, duty, opts, rpm_ref=None) -> dict:
    """The ripples per motor revolution from the data (hpddo ripple --calibrate), on the bursts as the count sees
    them (sync.prepare): over the driven windows (duty > 0; a mean current of opts.floor_A or more, in either
    direction, where the bursts hold the mean) whose lines form a rotation comb (not those whose health lines name
    a damaged commutator: a bar's fault puts lines at the even multiples, whose spacing is twice the rotation), the
    multiple of the rotation frequency at which the strongest line sits (comb.rotation_comb); with an encoder or
    tachometer speed per window (rpm_ref, output shaft), also the strongest line (encoder_lines) over the motor's
    rotation frequency, rpm_ref x opts.gear_ratio / 60, where it lies within CALIBRATE_WHOLE of a whole number; a
    window where that number is under COMMUTATION_MIN_MULTIPLE has a rotation line the strongest and names none.
    Each source names the number that CALIBRATE_AGREE of its windows (at least CALIBRATE_MIN_WINDOWS; the comb's
    damaged windows and the encoder's rotation-line windows among them, which agree on none: line.damaged_windows)
    agree on, or says that they do not agree; where the comb and the encoder name different numbers, the
    encoder's (a measurement of the revolutions) is named and the disagreement said. Returns a dict: per source the
    windows used and the counts of each number, the number named (0 where none), and a statement."""
    import collections

    n = len(bursts)
    raw = bursts
    bursts = sync.prepare(bursts)  # as the count sees them: a free-running PWM's synchronous average off
    duty = np.full(n, np.nan) if duty is None else np.asarray(duty, float)
    ref = None if rpm_ref is None else np.asarray(rpm_ref, float)
    comb_m, enc_m = collections.Counter(), collections.Counter()
    driven = damaged = uneven = rotation = 0
    for k in range(n):
        x = bursts.current_A(k)
        if len(x) < 16 or bursts.refusal(k) or not (np.isfinite(duty[k]) and duty[k] > 0) \
                or (sync.holds_mean(bursts) and abs(x.mean()) < opts.floor_A):  # an AC-coupled capture holds no mean
            continue
        driven += 1
        found, comb, res, bad = window_comb(bursts, k, opts)
        if bad:  # a damaged commutator's lines are not the rotation's comb (nor an uneven one's: it may be damaged)
            damaged += 1
            uneven += bad == "uneven"
        elif comb is not None:
            comb_m[comb.multiple] += 1
        if ref is not None and np.isfinite(ref[k]) and ref[k] > 0:
            strong = encoder_lines(found, bursts, res)
            if strong:
                per_rev = strong[0].hz / (ref[k] * opts.gear_ratio / 60.0)
                whole = round(per_rev)
                if 1 <= whole < rc.COMMUTATION_MIN_MULTIPLE and abs(per_rev / whole - 1.0) <= CALIBRATE_WHOLE:
                    rotation += 1  # a rotation line is the strongest: no commutator ripples so few times a turn
                elif whole >= 1 and abs(per_rev / whole - 1.0) <= CALIBRATE_WHOLE:
                    enc_m[int(whole)] += 1
    out = {"driven_windows": driven, "damaged_windows": damaged, "uneven_windows": uneven,
           "rotation_line_windows": rotation}
    health = _health_word(damaged, uneven)
    said = []
    for name, counts, how in (("comb", comb_m, "the comb of rotation lines"),
                              ("encoder", enc_m, "the strongest line against the encoder's speed")):
        if name == "encoder" and ref is None:
            continue
        used = int(sum(counts.values()))
        top, top_n = counts.most_common(1)[0] if counts else (0, 0)
        # the damaged windows among the comb's, and the encoder's windows whose strongest line is a rotation line:
        # agreeing with no figure (line.damaged_windows)
        other = damaged if name == "comb" else rotation
        other_text = ((f"{health} {damaged}" if name == "comb" else
                       f"a rotation line the strongest in {rotation} (once or twice a revolution: an asymmetry "
                       "stronger than the ripple, a damaged commutator, a shorted coil or a load that pulses with the "
                       "shaft)") if other else "")
        among = used + other
        named = int(top) if used >= CALIBRATE_MIN_WINDOWS and top_n >= CALIBRATE_AGREE * among else 0
        out[name] = {"windows": used, "counts": {str(m): int(c) for m, c in sorted(counts.items())},
                     "ripples_per_rev": named}
        if not used:
            said.append(f"{how}: no window shows it" + (f" ({other_text} of {among})" if other else ""))
        elif used < CALIBRATE_MIN_WINDOWS:
            said.append(f"{how}: too few windows (" + ", ".join(f"{m} in {c}" for m, c in counts.most_common(4))
                        + f" of {used}, under {CALIBRATE_MIN_WINDOWS}" + (f"; {other_text}" if other else "") + ")")
        elif named:
            said.append(f"{how}: {named} ripples per revolution ({top_n} of {among} windows)")
        else:
            said.append(f"{how}: the windows do not agree (" + ", ".join(
                f"{m} in {c}" for m, c in counts.most_common(4)) + (f", {other_text}" if other else "")
                + f" of {among})")
    # the encoder measures the revolutions; the comb infers them: where both name a number and they differ,
    # the encoder's is named and the disagreement said
    names = {out[s]["ripples_per_rev"] for s in ("comb", "encoder") if s in out and out[s]["ripples_per_rev"]}
    enc = out.get("encoder", {}).get("ripples_per_rev", 0)
    out["ripples_per_rev"] = enc or (next(iter(names)) if len(names) == 1 else 0)
    given = getattr(opts, "ripples_per_rev", None)
    head = (f"the ripple is {out['ripples_per_rev']} per revolution" if out["ripples_per_rev"]
            else "the ripples per revolution are not determined")
    if len(names) > 1:
        head += " (the comb and the encoder disagree: the encoder's is named)"
    if out["ripples_per_rev"] and given and given != out["ripples_per_rev"]:
        head += f", not the {given} given"
    out["statement"] = (f"{head}: " + "; ".join(said) + f" (of {driven} driven windows"
                        + (f"; {damaged} with {_health_lines(damaged, uneven)}, left out of the comb" if damaged else "")
                        + ")")
    # a declared PWM the data do not show: both sources read lines that may be the PWM's (sync.pwm_unseen)
    unseen = sync.pwm_unseen(raw)
    if unseen is not None:
        for name in ("comb", "encoder"):
            if name in out:
                out[name]["ripples_per_rev"] = 0
        out["ripples_per_rev"] = 0
        out["statement"] = (f"the ripples per revolution are not determined: {sync.unseen_reason(unseen, bursts.pwm_hz)}"
                            f"; what the lines would say: {out['statement']}")
    return out


#: calibrate_ke: a window's back-EMF E = V - I Ra must stand this many times over the voltage the prior does
#: not know (u: a brush drop, Ra's error times I) to tell Ke: under it E / w is the unknown voltage's, not
#: Ke's (a shaft standing at a fixed line: hum, a bus aliased into the band, with E a brush drop)
KE_MIN_EMF_OVER_U = 2.0
#: the largest relative doubt calibrate_ke states: u' = a + b <= sqrt(2) hypot(a, b) = sqrt(2) u and E >= KE_MIN_EMF_OVER_U u
KE_DOUBT_MAX = math.sqrt(2.0) / (KE_MIN_EMF_OVER_U - math.sqrt(2.0))


def ke_evidence(bursts, duty, v_V, i_A, ra_ohm: float, opts: Options) -> dict:
    """The windows that tell Ke (V s/rad, output shaft) without an encoder, each as calibrate_ke weighs
    it: the ripple speed w of the windows where the count alone (no prior) is confident, against the
    back-EMF E = V - I Ra, where E stands KE_MIN_EMF_OVER_U times over u, the voltage the prior does
    not know (opts.prior_unmodelled_V, and Ra's error opts.prior_ra_rel times I). Returns a dict of
    arrays over those windows: `ke` (E / w), `weight` ((w / u)^2: slow, loaded windows weigh little),
    `doubt` (u' / (E - u'), the relative error of E / w where the unmodelled voltage and Ra's error are in
    every window the same way: u' their sum, opts.prior_unmodelled_V + opts.prior_ra_rel Ra |I|; at most
    KE_DOUBT_MAX) and `placed` (whether the window's rotation comb places its line at opts.ripples_per_rev)."""
    # no window's line is refused for lying at an undeclared mains multiple (estimate's unplaced_hum): E >= 2 u
    # shows the shaft turning, so its line is not a standing shaft's hum (the twin's long recording, duty 0.8
    # under load 2, puts the ripple at 51-52 Hz, beside 50 Hz)
    df = estimate(bursts, duty, None, opts, unplaced_hum=False)
    w = df["rpm"].to_numpy() * 2 * math.pi / 60.0
    i = np.asarray(i_A, float)
    e = np.asarray(v_V, float) - i * ra_ohm
    u = np.hypot(opts.prior_unmodelled_V, opts.prior_ra_rel * ra_ohm * np.abs(i))
    # the doubt's bound adds the two, not in quadrature: a brush drop and a winding warmer than the Ra given both
    # put E above Ke w (the twin's load run: Ke 8.7-11.9 % above the truth, stated +-10.5 % with u; +-15.5 % so)
    u_bound = opts.prior_unmodelled_V + opts.prior_ra_rel * ra_ohm * np.abs(i)
    ok = df["confident"].to_numpy() & (w > 0) & (e >= KE_MIN_EMF_OVER_U * u)
    placed = df["multiple"].to_numpy(int)[ok] == opts.ripples_per_rev
    w, e, u, u_bound = w[ok], e[ok], u[ok], u_bound[ok]
    return {"ke": e / w, "weight": (w / u) ** 2, "doubt": u_bound / (e - u_bound), "placed": placed}


def ke_of(evidence: dict) -> tuple:
    """Ke from windows of ke_evidence (their arrays, possibly pooled over recordings): the weighted
    median of E / w, and its relative doubt, the windows' doubts averaged with the same weights (at
    most KE_DOUBT_MAX). Returns (ke, windows, doubt); (NaN, 0, NaN) where there are none."""
    ke, weight = np.asarray(evidence["ke"], float), np.asarray(evidence["weight"], float)
    if ke.size == 0:
        return math.nan, 0, math.nan
    order = np.argsort(ke)
    cw = np.cumsum(weight[order])
    rel = float(np.sum(weight * np.asarray(evidence["doubt"], float)) / np.sum(weight))
    return float(ke[order][np.searchsorted(cw, 0.5 * cw[-1])]), int(ke.size), rel


def placed_only(evidence: dict) -> dict:
    """ke_evidence's windows whose rotation comb places their line at the figure given."""
    keep = np.asarray(evidence["placed"], bool)
    return {k: np.asarray(v)[keep] for k, v in evidence.items()}


def calibrate_ke(bursts, duty, v_V, i_A, ra_ohm: float, opts: Options):
    """Ke (V s/rad, output shaft) for the back-EMF prior without an encoder (ke_evidence, ke_of): from
    the windows whose rotation comb places the line at opts.ripples_per_rev, where any do; else from
    every window that tells Ke. Each window's E / w is off by up to u / w, all of them the same way where
    one brush drop is in every one: against Ke w = E - u' at the least, Ke's relative doubt is u' / (E - u')
    (ke_evidence; a calibration from slow windows alone carries a large one).
    Returns (ke, windows used, its relative doubt); (NaN, 0, NaN) where no window tells it."""
    # the windows whose rotation comb places their line at the figure given, where there are any: a window without
    # a comb counts its strongest line, which a strongly eccentric rotor's once-per-revolution line can be (a
    # 5-bar commutator's ripple under it in the independent commutator simulation: Ke 10x the motor's, and the
    # comb windows' own lines then `far` from the prior); the comb is the one check of the line's identity here
    return calibrated(ke_evidence(bursts, duty, v_V, i_A, ra_ohm, opts))


def calibrated(evidence: dict) -> tuple:
    """calibrate_ke's Ke from a recording's ke_evidence: (ke, windows used, its relative doubt)."""
    placed = placed_only(evidence)
    return ke_of(placed if placed["ke"].size else evidence)
