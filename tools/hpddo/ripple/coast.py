"""Online Ra and winding temperature from a coast probe (issue 33, item 7; docs/ripple-coast.md):
the drive held off for a few milliseconds, the open terminals show the back-EMF itself, so Ke is
measured against the ripple's counted speed, and Ra follows from the driven rows around it,
separating the copper from the magnets.

Per probe (a row of the log at duty 0 with its burst of both channels, logs/coast.ProbeBursts):

1. the current freewheels to zero through the diode (La / R, hastened by the back-EMF): the probe
   is usable from the first current sample after which every one reads under options.decayed_A,
   with at least min_emf_samples voltage samples left; else refused, in words;
2. the back-EMF: the terminal voltage after the decay, a quadratic in time (the shaft slows at its
   mechanical time constant), read at the moment the drive's torque effectively ended,
   t_a = Q / I (Q the charge the freewheel still carried, the current samples joined by straight
   lines, the last two carried on to zero; I the mean current before the cut: at
   steady speed Ke I balances the friction, so w(t) = w_cut - a (t - t_a) to first order);
3. the speed at the cut: the ripple counted (ripple.count.estimate_window) over count_s of the
   drive before the cut and after the recovery, interpolated linearly to the cut; both counts
   must be confident, at one duty and load; Ke = E / w_cut, its uncertainty from the fit's and the counts';
4. Ra per driven span between two probes (one duty and load, recovery left out): the rows'
   V - Ke w - drop = Ra I summed, Ke the median of the probes within ke_window_s, w linear
   between the span's two counts, the declared brush drop times the share of the time the current
   flows (conducting_share): Ra = (sum V - Ke sum w - n drop) / sum I, its uncertainty from the
   rows' scatter and Ke's;
5. Ra at the probe: a straight line in time through the spans of its stretch (one duty and load) within
   ra_window_s, inverse-variance weighted (ra_at): the copper's heat capacity keeps its temperature
   straight over that window at one drive, and the fit never crosses a change of duty or load, so a
   load step's heating is followed; its uncertainty the line's, Ke's, and the model's (the line against a
   quadratic through the same spans, where the copper bends); not given where it exceeds max_ra_rel_sd;
   the winding's temperature
   T = T_ref + (Ra / Ra_ref - 1) / copper's coefficient (model.effects.COPPER_TC_PER_K), Ra_ref at
   T_ref given or the first probe's Ra at the log's first temperature reading (read_winding), given
   only where its 99 % interval lies within options.winding_tolerance_K.

Where the data cannot support a figure, the probe's `reason` says why and its figures are NaN;
a record without a probe gives NO_PROBE and no table.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd

from ..model.effects import COPPER_TC_PER_K
from . import sync
from .count import count_sd_rpm, estimate_window
from .options import CoastOptions, Options
from .prior import m2_prior_rpm, m2_prior_sd_rpm, rpm_per_amp

NO_PROBE = ("no coast probe in the record: no row with the drive off carries a burst of the terminal voltage, "
            "so the back-EMF cannot be seen and neither Ke nor Ra is measured")
NO_PERIOD = ("the log has no row period (fewer than two rows, or no time between them), so no driven span "
             "around a probe can be counted and neither Ke nor Ra is measured")
NOT_DECAYED = "the current did not freewheel to zero within the probe, so the terminals never showed the back-EMF"
FEW_EMF = "too few voltage samples after the current's decay for the back-EMF's curve"
STANDING = "the terminals show no back-EMF after the decay: the shaft stands, Ke cannot be measured"
NO_COUNT = "the speed around the probe is not confident"
NO_SPAN = "no driven span of one duty and load beside the probe with a measured Ke and counted speeds"
UNCERTAIN = "the driven spans around the probe leave Ra too uncertain"
NO_REFERENCE = ("no reference for the winding's temperature: no Ra given at a known temperature and no temperature "
                "reading at the log's start, so Ra is given and the temperature is not")
WINDING_UNCERTAIN = "Ra is given, the winding's temperature is not: its 99 % interval exceeds the tolerance"
FIRST_PROBE_REFERENCE = ("the winding's temperature is read against the first probe's Ra taken at the log's first "
                         "temperature reading; that Ra's uncertainty is in each temperature's, but not the warming "
                         "between the reading and the probe (the copper heats within seconds of a start): "
                         "--ra-ref OHM C, a multimeter's Ra at a known temperature, removes both")
WINDING_Z = 2.576  # the 99 % interval of a temperature, in standard uncertainties (its error is about normal: the
#                    coast study's errors fall within 1.96 of them at 97.5 % of probes, within 2.576 at 99.7 %)


@dataclasses.dataclass
class CoastResult:
    """The probes' figures (a DataFrame, one row per probe: t_s, row, e_V, ke_vs_per_rad, ke_sd, rpm_cut,
    ra_ohm, ra_sd_ohm, winding_C, winding_sd_K, reason) or, where the record holds no probe, the
    statement alone (`statement`, table None); `statement` also says where no temperature can be given, or
    what the first probe's reference leaves out of the temperatures' uncertainties."""

    table: pd.DataFrame | None
    statement: str = ""
    ra_ref_ohm: float = math.nan
    ra_ref_C: float = math.nan
    spans: pd.DataFrame | None = None  # the driven spans' Ra (t_mid, stretch, ra, sd_rows, sd_ke)


def _rad_s(rpm):
    return np.asarray(rpm, float) * 2 * math.pi / 60.0


def _zero_time(t_i, i_A, m: int) -> float:
    """When the freewheel's current reached zero (s after the cut), m the first sample of the decayed
    tail: the line through the last two samples above it carried on to zero (the freewheel falls almost
    straight: L di/dt = -(Vf + E + vb) - R i), within the interval before sample m; the middle of that
    interval where one sample alone lies above."""
    if m == 0:
        return float(t_i[0])
    lo, hi = float(t_i[m - 1]), float(t_i[m])
    if m >= 2 and i_A[m - 2] > i_A[m - 1]:
        return float(np.clip(lo + i_A[m - 1] * (lo - t_i[m - 2]) / (i_A[m - 2] - i_A[m - 1]), lo, hi))
    return 0.5 * (lo + hi)


def back_emf(t_i, i_A, t_v, v_V, i_before_A: float, opts: CoastOptions):
    """(E at t_a (V), its standard uncertainty, t_a (s after the cut), '' or why not) of one probe."""
    above = np.flatnonzero(np.abs(i_A) >= opts.decayed_A)
    m = 0 if not len(above) else int(above[-1]) + 1
    if m >= len(i_A):
        return math.nan, math.nan, math.nan, NOT_DECAYED
    t_d = t_i[m]
    sel = t_v >= t_d
    if sel.sum() < opts.min_emf_samples:
        return math.nan, math.nan, math.nan, f"{FEW_EMF} ({int(sel.sum())} < {opts.min_emf_samples})"
    q = float(np.trapezoid(np.append(np.clip(i_A[:m], 0.0, None), 0.0), np.append(t_i[:m], _zero_time(t_i, i_A, m))))
    t_a = q / i_before_A if i_before_A > opts.decayed_A else 0.0
    x, y = t_v[sel] - t_a, v_V[sel]
    a = np.column_stack([np.ones_like(x), x, x * x])
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    dof = max(1, len(y) - 3)
    s2 = float(np.sum((y - a @ coef) ** 2)) / dof
    cov = s2 * np.linalg.inv(a.T @ a)
    e = float(coef[0])
    if not e > 0.05:
        return math.nan, math.nan, math.nan, STANDING
    return e, math.sqrt(max(cov[0, 0], 0.0)), t_a, ""


def _count(bursts, rows_pos, rows, duty, prior, prior_sd, per_A, opts: Options):
    """The ripple count over the bursts of `rows` (contiguous log rows), one window: (rpm, sd, '' or why)."""
    idx = [rows_pos.get(int(r)) for r in rows]
    if not rows or any(j is None for j in idx):
        return math.nan, math.nan, "no current burst there"
    codes = np.concatenate([bursts.codes[j] for j in idx])
    one = sync.prepare(bursts.one(idx[0], codes), "bursts")  # free-running: the PWM's average off the joined burst
    out = estimate_window(one, 0, float(np.median(duty)), float(np.median(prior)), opts,
                          prior_sd=np.median(prior_sd, axis=0), rpm_per_A=per_A)
    if out["key"] or not out["confidence"] > 0:
        return math.nan, math.nan, out["reason"] or "not confident"
    row = pd.DataFrame([{**out, "confident": True}])
    return float(out["rpm"]), float(count_sd_rpm(row)[0]), ""


def conducting_share(bursts, rows_pos, rows, decayed_A: float) -> float:
    """The share of the time the armature current flows over `rows` (log rows), from their bursts: the
    brush drop acts only then (discontinuous conduction under a slow PWM leaves the current at zero for
    part of each period). Free-running samples fall at every phase of the PWM period, so the share of
    them above decayed_A measures it; synchronous ones sit in the on-time and cannot, so 1 (continuous
    conduction, as the PWM at the sample rate gives a running motor)."""
    from ..logs import ripple as rf
    idx = [rows_pos.get(int(r)) for r in rows]
    idx = [j for j in idx if j is not None]
    if bursts.sampling != rf.FREE or not idx:
        return 1.0
    x = np.concatenate([bursts.current_A(j) for j in idx])
    return float(np.mean(x > decayed_A))


def ra_at(spans: pd.DataFrame, t_s: float, stretch: int, window_s: float):
    """(Ra, its standard uncertainty) at t_s: a straight line in time through the driven spans of `stretch`
    (one duty and load) whose middle lies within window_s of t_s, each weighted by its rows' variance
    (the spans' noise is independent: each its own stretch of rows); the line's variance at t_s scaled up
    by the reduced chi-square where the spans scatter more than their stated uncertainties, Ke's
    part (shared by the spans) added, and the model's: from four spans on, the difference at t_s between
    the line and a quadratic fitted the same way. (NaN, NaN) where fewer than three spans lie there."""
    near = spans[(spans["stretch"] == stretch) & (np.abs(spans["t_mid"] - t_s) <= window_s)]
    if len(near) < 3:
        return math.nan, math.nan
    x = (near["t_mid"].to_numpy() - t_s) / window_s
    a = np.column_stack([np.ones_like(x), x])
    wgt = 1.0 / near["sd_rows"].to_numpy() ** 2
    y = near["ra"].to_numpy()
    cov = np.linalg.inv((a.T * wgt) @ a)
    coef = cov @ ((a.T * wgt) @ y)
    chi2 = float(np.sum(wgt * (y - a @ coef) ** 2)) / (len(y) - 2) if len(y) > 2 else 1.0
    sd = math.hypot(math.sqrt(cov[0, 0] * max(1.0, chi2)), float(np.mean(near["sd_ke"])))  # Ke's part is shared
    if len(y) >= 4:  # the model's part: a quadratic through the same spans explains them about as well; where the
        # copper bends (a stretch's first winding time constants) or the line reaches to one side of the probe only,
        # the two part at the probe, and their difference joins the uncertainty
        a2 = np.column_stack([np.ones_like(x), x, x * x])
        quad = np.linalg.solve((a2.T * wgt) @ a2, (a2.T * wgt) @ y)
        sd = math.hypot(sd, float(quad[0] - coef[0]))
    return float(coef[0]), sd


def estimate(log: pd.DataFrame, bursts, probes, opts: Options, ra_ohm: float, ke_vs_per_rad: float,
             copts: CoastOptions = CoastOptions()) -> CoastResult:
    """Ke, Ra and the winding's temperature at every coast probe of a record: its log (t_s, duty, v_V,
    i_A, temp_C; load where logged), its current bursts (logs.ripple.Bursts, seq = the log's rows), its
    probes (logs.coast.ProbeBursts: <condition>.coast.csv, or the twin's). ra_ohm, ke_vs_per_rad: the
    nominal figures of the back-EMF prior that places the ripple's line (ripple.prior). A CoastResult."""
    from ..logs.errors import InputError
    missing = [c for c in ("t_s", "duty", "v_V", "i_A") if c not in log]
    if missing:
        raise InputError(f"coast probe: the log lacks the column(s) {', '.join(missing)}")
    if probes is None or len(probes) == 0:
        return CoastResult(None, NO_PROBE)
    t = log["t_s"].to_numpy(float)
    duty, v, i = (log[c].to_numpy(float) for c in ("duty", "v_V", "i_A"))
    load = log["load"].to_numpy() if "load" in log else np.zeros(len(log))
    Ts = float(np.median(np.diff(t))) if len(t) > 1 else math.nan
    if not (Ts > 0 and math.isfinite(Ts)):
        return CoastResult(None, NO_PERIOD)
    seq = log["seq"].to_numpy() if "seq" in log else np.arange(len(log))
    row_of = {int(s): k for k, s in enumerate(seq)}
    b = bursts
    pos = {row_of[int(s)]: j for j, s in enumerate(b.seq) if int(s) in row_of}
    prior = m2_prior_rpm(v, i, ra_ohm, ke_vs_per_rad)
    prior_sd = m2_prior_sd_rpm(v, i, ra_ohm, ke_vs_per_rad, opts)
    per_A = rpm_per_amp(ra_ohm, ke_vs_per_rad)
    n_count = max(1, int(round(copts.count_s / Ts)))
    n_rec = int(round(copts.recovery_s / Ts))
    # the stretches of one duty and load, numbered (a probe's row takes its drive's)
    drive = duty.copy()
    for s_ in probes.seq:
        k_ = row_of.get(int(s_))
        if k_ is not None and k_ > 0:
            drive[k_] = drive[k_ - 1]
    stretch = np.cumsum(np.r_[0, (np.diff(drive) != 0) | (load[1:] != load[:-1])])
    recs = []
    for j in range(len(probes)):
        k = row_of.get(int(probes.seq[j]))
        r = dict(t_s=float(probes.t_s[j]), row=k, e_V=math.nan, e_sd_V=math.nan, rpm_cut=math.nan, rpm_sd=math.nan,
                 ke_vs_per_rad=math.nan, ke_sd=math.nan, rpm_after=math.nan, reason="")
        recs.append(r)
        if k is None:
            r["reason"] = "the probe's row is not in the log"
            continue
        before = list(range(max(0, k - n_count), k))
        after = list(range(k + 1 + n_rec, min(len(t), k + 1 + n_rec + n_count)))
        rb, sb, why_b = _count(b, pos, before, duty[before], prior[before], prior_sd[before], per_A, opts)
        ra_, sa, why_a = (_count(b, pos, after, duty[after], prior[after], prior_sd[after], per_A, opts)
                          if after else (math.nan, math.nan, "no rows after the probe"))
        ti, ia = probes.current(j)
        tv, vv = probes.voltage(j)
        i_before = float(np.mean(i[before])) if before else math.nan
        e, e_sd, t_a, why = back_emf(ti, ia, tv, vv, i_before, copts)
        r.update(e_V=e, e_sd_V=e_sd)
        if why:
            r["reason"] = why
            continue
        if why_b or why_a:
            r["reason"] = f"{NO_COUNT} ({why_b or why_a})"
            continue
        around = before + after
        if np.ptp(duty[around]) > 0 or np.ptp(load[around]) > 0:
            r["reason"] = f"{NO_COUNT}: the duty or the load changed across the probe, so no speed is interpolated"
            continue
        tb, ta = t[k] - 0.5 * len(before) * Ts, t[after[0]] + 0.5 * len(after) * Ts
        rpm_cut = rb + (ra_ - rb) * (t[k] - tb) / (ta - tb)
        rpm_sd = math.hypot(sb, sa)  # an upper bound of the interpolation's
        w = float(_rad_s(rpm_cut))
        ke = e / w
        r.update(rpm_cut=rpm_cut, rpm_sd=rpm_sd, rpm_before=rb, rpm_after=ra_, t_after=ta, t_before=tb,
                 ke_vs_per_rad=ke, ke_sd=ke * math.hypot(e_sd / e, rpm_sd / rpm_cut))
    tab = pd.DataFrame(recs)
    ok = tab["reason"] == ""
    # Ra over the driven spans between two usable probes
    spans = []
    ok_idx = np.flatnonzero(ok.to_numpy())
    for a_, b_ in zip(ok_idx[:-1], ok_idx[1:]):
        ka, kb = int(tab.at[a_, "row"]), int(tab.at[b_, "row"])
        rows = np.arange(ka + 1 + n_rec, kb)
        if len(rows) < 2 or np.ptp(duty[rows]) > 0 or np.ptp(load[rows]) > 0 or not duty[rows[0]] > 0:
            continue
        tm = 0.5 * (t[rows[0]] + t[rows[-1]])
        near = ok & (np.abs(tab["t_s"] - tm) <= copts.ke_window_s)
        ke = float(np.median(tab.loc[near, "ke_vs_per_rad"]))
        ke_sd = float(1.2533 * np.sqrt(np.mean(tab.loc[near, "ke_sd"] ** 2)) / math.sqrt(near.sum()))
        t0, r0 = float(tab.at[a_, "t_after"]), float(tab.at[a_, "rpm_after"])
        t1, r1 = float(tab.at[b_, "t_before"]), float(tab.at[b_, "rpm_before"])
        w = _rad_s(r0 + (r1 - r0) * (t[rows] + 0.5 * Ts - t0) / (t1 - t0))
        heads = range(ka + 1 + n_rec, ka + 1 + n_rec + n_count)
        share = conducting_share(b, pos, list(heads) + list(range(kb - n_count, kb)), copts.decayed_A)
        drop = copts.brush_drop_V * share * (i[rows] > copts.decayed_A)
        si = float(np.sum(i[rows]))
        if not si > 0:
            continue
        ra = float(np.sum(v[rows] - ke * w - drop)) / si
        resid = v[rows] - ke * w - drop - ra * i[rows]
        sd_rows = float(np.std(resid, ddof=1)) / math.sqrt(len(rows)) / float(np.mean(i[rows]))
        spans.append(dict(t_mid=tm, stretch=int(stretch[rows[0]]), ra=ra, sd_rows=sd_rows,
                          sd_ke=ke_sd * float(np.mean(w)) / float(np.mean(i[rows]))))
    sp = pd.DataFrame(spans, columns=["t_mid", "stretch", "ra", "sd_rows", "sd_ke"])
    tab["stretch"] = [int(stretch[k - 1]) if k else -1 for k in tab["row"].fillna(0).astype(int)]
    tab["ra_ohm"] = math.nan
    tab["ra_sd_ohm"] = math.nan
    for j in ok_idx:
        ra, sd = ra_at(sp, float(tab.at[j, "t_s"]), int(tab.at[j, "stretch"]), copts.ra_window_s)
        if not math.isfinite(ra):
            tab.at[j, "reason"] = NO_SPAN
            continue
        if not sd / ra <= copts.max_ra_rel_sd:
            tab.at[j, "reason"] = f"{UNCERTAIN} ({sd / ra:.1%} > {copts.max_ra_rel_sd:.1%})"
            continue
        tab.at[j, "ra_ohm"], tab.at[j, "ra_sd_ohm"] = ra, sd
    bad = tab["reason"] != ""
    tab.loc[bad, ["ra_ohm", "ra_sd_ohm"]] = math.nan  # Ke stays where it was measured
    return read_winding(CoastResult(tab, "", math.nan, math.nan, sp), copts, first_reading_C(log))


def first_reading_C(log: pd.DataFrame) -> float:
    """The log's first temperature reading (the motor at rest before the run, its winding at the case's): the
    temperature of the first probe's reference where no Ra is given at a known one; NaN where none."""
    return float(log["temp_C"].iloc[0]) if "temp_C" in log and len(log) else math.nan


def read_winding(res: CoastResult, copts: CoastOptions, first_reading_C: float = math.nan) -> CoastResult:
    """res with each probe's winding temperature read from its Ra against the reference: copts.ra_ref_ohm at
    ra_ref_C where given, else the first probe's Ra at first_reading_C (the log's first temperature
    reading; its uncertainty joins every temperature's, and the statement says what it leaves out), else
    none (NO_REFERENCE). A temperature whose 99 % interval (WINDING_Z standard uncertainties) is wider than
    copts.winding_tolerance_K is not given; its probe keeps Ra and says why. Any earlier reading of res's
    temperatures is replaced (so one estimate can be read against another reference)."""
    tab = res.table.copy()
    tab["reason"] = tab["reason"].where(~tab["reason"].str.startswith(WINDING_UNCERTAIN), "")
    given = tab["ra_ohm"].notna()
    ra_ref_sd = 0.0  # a multimeter's Ra: exact here (its tolerance is the user's to add to --ra-ref's figure)
    if copts.ra_ref_ohm is not None:
        ra_ref, t_ref = float(copts.ra_ref_ohm), float(copts.ra_ref_C)
        statement = ""
    elif given.any() and math.isfinite(first_reading_C):
        first = int(np.flatnonzero(given.to_numpy())[0])
        ra_ref, t_ref = float(tab.at[first, "ra_ohm"]), float(first_reading_C)
        ra_ref_sd = float(tab.at[first, "ra_sd_ohm"])
        statement = FIRST_PROBE_REFERENCE
    else:
        ra_ref, t_ref = math.nan, math.nan
        statement = NO_REFERENCE if given.any() else ""
    tab["winding_C"] = t_ref + (tab["ra_ohm"] / ra_ref - 1.0) / COPPER_TC_PER_K
    # T - T_ref = (Ra / Ra_ref - 1) / alpha: the probe's Ra and the reference's uncertainties in quadrature (the
    # reference probe's own temperature, T_ref, then carries its uncertainty twice over: an upper bound)
    tab["winding_sd_K"] = np.hypot(tab["ra_sd_ohm"] / ra_ref, tab["ra_ohm"] * ra_ref_sd / ra_ref ** 2) / COPPER_TC_PER_K
    wide = given & ~(WINDING_Z * tab["winding_sd_K"] <= copts.winding_tolerance_K) & math.isfinite(ra_ref)
    for j in np.flatnonzero(wide.to_numpy()):
        tab.at[j, "reason"] = (f"{WINDING_UNCERTAIN} (+-{WINDING_Z * tab.at[j, 'winding_sd_K']:.1f} K against "
                               f"+-{copts.winding_tolerance_K:g} K)")
    tab.loc[~given | wide, ["winding_C", "winding_sd_K"]] = math.nan
    return dataclasses.replace(res, table=tab, statement=statement, ra_ref_ohm=ra_ref, ra_ref_C=t_ref)
