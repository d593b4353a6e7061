"""Fast logs: the dynamic family (inertia J, viscous B and Coulomb Tc friction, the inductance La;
schema.py, the dynamic family) identified from recordings at 50 Hz and up, with intervals, the
speed's measured lag behind the duty steps, and how much of the held-out residual a model with
the family explains.

The mechanical balance at the output shaft, Kt i = J dw/dt + B w + Tc sgn(w) + T_load (Kt = Ke
in SI), is used in two parts:

* settled rows (SETTLE_S after each change of duty or load, the shaft turning): per segment the
  means obey Kt I = B w + Tc + T_load. At load state 0 (no external load: the sweep) T_load = 0
  and the line through the segments gives B and Tc; at any other load state the line is the
  friction plus that load's torque (its own line; the load is not known apart from it).
* each duty step (the load state the same on both sides): the impulse balance over the step,
  J (w_after - w_before) = sum over the step's rows of T (Kt I - B w - Tc), with w_before and
  w_after the means of AVG_S of settled rows before the step and after the transient. The sums
  average the channels' noise and the encoder's quantisation out; J is the least-squares slope
  over the steps.

The speed: from the encoder's periods where the log has them (enc_period_s with
encoder_counts_per_rev: the speed at each row's end, the row's mean the average of its two
ends), else the counts (rpm_ref). La: the voltage balance's residual V - Ra I - Ke w against the
current's backward difference (I_k - I_(k-1)) / T, with (I_(k+1) - I_(k-2)) / T as the
instrument, so that the row's own noise, in both, does not bias it.

Intervals: a bootstrap over whole segments (BOOT resamples, the seed fixed): each resample draws
segments with replacement, refits the friction lines from the drawn segments' settled means and
J from the drawn steps; the 2.5 and 97.5 % quantiles. A quantity is not determined by these
recordings when the rate is below schema.DYNAMICS_MIN_RATE_HZ (a row then averages over the
transients: the motor's time constants are tens of ms), when too few steps or segments hold it,
or when its interval reaches outside its physical range.

The held-out figure: J, B, Tc (and La where determined) from the training rows only; the
observer of the boards (model/dynamics_ref.py, hpddo/dynamics.h) run over the recording with the
model under test's speed as its measurement; the RMSE on the held-out rows before (the model
under test) and after (with the observer), against the best speed the log has (the encoder's
periods where present, else its counts).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import stats

from .. import schema
from ..logs import dataset
from . import dynamics_ref
from .physics import RPM_PER_RAD_S
from .interval import LEVEL, Interval

MIN_RATE_HZ = schema.DYNAMICS_MIN_RATE_HZ
SETTLE_S = 0.25      # after a change of duty or load, rows this much later are settled (> 5 mechanical tau)
STEP_SPAN_S = 0.1    # a step's transient is over after this (3.7 x the twin's 27 ms lag): the impulse's span
AVG_S = 0.1          # the settled speed before and after a step: the mean over this long
MIN_W_RAD_S = 2.0    # a turning shaft (Coulomb friction acts): faster than this
LA_MIN_RATE_HZ = 1000.0  # La from rows this fast: slower, the current's rise (La / R, about 1 ms) is over within a row
MIN_STEP_RAD_S = 3.0  # a step that moves the speed by less says nothing of J
BOOT = 400
SEED = 21
TAU_OBS_GRID_S = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2)  # the observer's time constant, chosen on training rows

NEEDS = ("a recording at 50 Hz or faster with steps of duty at no load (several, each dwelling 0.5 s or "
         "longer), with the encoder's periods (the enc_period_s column and encoder_counts_per_rev, "
         "docs/bench-log.md) where the board can time its counts")
LA_NEEDS = "a recording at 1 kHz or faster with steps of duty (the current's rise lasts La / R, about a ms)"


@dataclasses.dataclass
class Dynamics:
    """What the fast recordings show of the motor's dynamics."""

    rate_hz: float                 # the fastest recording's rate
    fast: list                     # names of the recordings at MIN_RATE_HZ and up
    speed_from: str                # "encoder periods" or "rpm_ref column" (or "" when no fast recording)
    steps: int = 0                 # duty steps used for J
    segments: int = 0              # settled segments used for B and Tc
    quantities: list = dataclasses.field(default_factory=list)  # Interval: J, B, Tc, La
    lag_s: float | None = None     # the speed's lag behind the duty steps: median time to 63 %
    lag_range_s: tuple | None = None
    tau_obs_s: float | None = None
    rmse_before: float | None = None   # held-out RMSE, RPM, of the model under test
    rmse_after: float | None = None    # ... with the dynamic family (the observer)
    reference: str = ""                # what the RMSE is against
    rate_corr: dict | None = None      # the residual's correlation with a rate, at the lags that share a row

    @property
    def determined(self) -> bool:
        return any(q.determined for q in self.quantities if q.field != "la_H")

    def by_field(self, field: str) -> Interval | None:
        return next((q for q in self.quantities if q.field == field), None)

    def to_json(self) -> dict:
        return {"rate_hz": self.rate_hz, "fast_recordings": self.fast, "speed_from": self.speed_from,
                "steps": self.steps, "segments": self.segments,
                "quantities": [q.to_json() for q in self.quantities],
                "lag_s": self.lag_s, "lag_range_s": list(self.lag_range_s) if self.lag_range_s else None,
                "tau_obs_s": self.tau_obs_s, "rmse_rpm": {"before": _finite(self.rmse_before),
                                                          "after": _finite(self.rmse_after), "against": self.reference},
                "rate_correlation": self.rate_corr, "text": self.text()}

    def text(self) -> str:
        """The dynamics in words: the identified family with its intervals, or why not."""
        if not self.fast:
            return (f"Dynamics (inertia, friction, inductance) not determined by these recordings: the fastest is "
                    f"at {self.rate_hz:.4g} Hz, where a row averages over the motor's transients (tens of ms); "
                    f"what would determine them: {NEEDS}.")
        parts = "; ".join(q.text() for q in self.quantities)
        head = (f"Dynamics from {', '.join(self.fast)} at {self.rate_hz:.4g} Hz ({self.steps} duty steps, "
                f"{self.segments} settled segments, speed from the {self.speed_from}): {parts}.")
        if self.lag_s is not None:
            head += (f" The speed lags the duty steps by {1e3 * self.lag_s:.0f} ms (63 % of each step, median; "
                     f"{1e3 * self.lag_range_s[0]:.0f}..{1e3 * self.lag_range_s[1]:.0f} ms).")
        if _finite(self.rmse_after) is not None and _finite(self.rmse_before) is not None:
            head += (f" With the family (the boards' observer, tau {1e3 * self.tau_obs_s:.0f} ms, fitted on the "
                     f"training rows) the held-out RMSE against the {self.reference} goes from "
                     f"{self.rmse_before:.3g} to {self.rmse_after:.3g} RPM.")
        return head


def _finite(x):
    """x, or None where it is no finite number (the JSON carries no NaN)."""
    return float(x) if x is not None and math.isfinite(x) else None


def _segments(rec: dataset.Recording) -> np.ndarray:
    """Segment id per row: a new one at each change of duty or load and at each restart of the clock."""
    df = rec.df
    duty = df["duty"].to_numpy(float)
    load = df["load"].to_numpy() if "load" in df else np.zeros(rec.n)
    new = np.zeros(rec.n, bool)
    new[1:] = (np.diff(duty) != 0) | (np.diff(load) != 0)
    new[dataset.segment_starts(rec)] = True
    new[0] = True
    return np.cumsum(new) - 1


def speed_rad_s(rec: dataset.Recording) -> tuple[np.ndarray, str]:
    """The row's mean speed, rad/s (NaN where not measured), and where it comes from."""
    df = rec.df
    counts = (df["rpm_ref"].to_numpy(float) / RPM_PER_RAD_S) if "rpm_ref" in df else np.full(rec.n, np.nan)
    per = dataset.enc_period_s(rec)
    cpr = dataset.sensor_meta(rec.meta, rec.source).get("encoder_counts_per_rev")
    if per is None or cpr is None:
        return counts, "rpm_ref column"
    w_end = np.where(np.isfinite(per), 2 * math.pi / (cpr * np.where(np.isfinite(per), per, 1.0)), 0.0)
    w_end = np.where(np.isfinite(per), w_end, np.where(np.isfinite(counts) & (counts < MIN_W_RAD_S), 0.0, np.nan))
    w = np.full(rec.n, np.nan)
    w[1:] = 0.5 * (w_end[1:] + w_end[:-1])
    w = np.where(np.isfinite(w), w, counts)
    return w, "encoder periods"


@dataclasses.dataclass
class _Seg:
    rec: int
    load: int
    start: int
    end: int
    settled: tuple | None   # (mean Kt I, mean w, rows) of the settled rows while turning
    step: tuple | None      # (T sum Kt I, T sum w, T rows turning, dw) of the step into this segment


def _summaries(rec, w, kt, T, rows_mask, ri) -> list:
    seg = _segments(rec)
    df = rec.df
    i = df["i_A"].to_numpy(float)
    load = df["load"].to_numpy() if "load" in df else np.zeros(rec.n, int)
    n_settle, n_avg = int(round(SETTLE_S / T)), max(1, int(round(AVG_S / T)))
    n_span = int(round(STEP_SPAN_S / T))
    out = []
    starts = np.flatnonzero(np.r_[True, np.diff(seg) != 0])
    ends = np.r_[starts[1:], rec.n]
    for k, (s, e) in enumerate(zip(starts, ends)):
        settled = None
        idx = np.arange(s + n_settle, e)
        idx = idx[rows_mask[idx] & np.isfinite(w[idx]) & (w[idx] > MIN_W_RAD_S)] if len(idx) else idx
        if len(idx) >= n_avg:
            settled = (float(np.mean(kt * i[idx])), float(np.mean(w[idx])), len(idx))
        step = None
        if k > 0 and load[s] == load[starts[k - 1]] and e - s >= n_span + n_avg and s - starts[k - 1] >= n_settle:
            before = np.arange(s - n_avg, s)
            after = np.arange(s + n_span, s + n_span + n_avg)
            span = np.arange(s, s + n_span)
            allrows = np.r_[before, span, after]
            if rows_mask[allrows].all() and np.isfinite(w[allrows]).all():
                dw = float(np.mean(w[after]) - np.mean(w[before]))
                # the impulse over the step's rows: the shaft is settled before and after, so w_before is the
                # speed at the step's start and w_after the one at the span's end (a shaft whose lag is over
                # STEP_SPAN_S / 3 still speeds up after it: _slower_than_the_windows)
                imp = span
                turning = w[imp] > MIN_W_RAD_S
                if abs(dw) >= MIN_STEP_RAD_S:
                    step = (float(T * np.sum(kt * i[imp])), float(T * np.sum(w[imp] * turning)),
                            float(T * np.sum(turning)), dw, float(T * np.sum(~turning * kt * i[imp])))
        out.append(_Seg(ri, int(load[s]), int(s), int(e), settled, step))
    return out


def _friction(segs) -> dict:
    """{load state: (B, Tc)} from the settled segments' means (a line through them), where two
    distinct speeds hold it."""
    out = {}
    for L in sorted({s.load for s in segs}):
        pts = [s.settled for s in segs if s.load == L and s.settled is not None]
        if len(pts) < 2:
            continue
        tq, w, n = (np.array(x) for x in zip(*pts))
        if np.ptp(w) < MIN_STEP_RAD_S:
            continue
        A = np.c_[w, np.ones_like(w)]
        wt = np.sqrt(n)
        b, tc = np.linalg.lstsq(A * wt[:, None], tq * wt, rcond=None)[0]
        out[L] = (float(b), float(tc))
    return out


def _inertia(segs, fr) -> tuple[float, int]:
    """J from the steps whose load state has a friction line: (J, steps); NaN when none."""
    num = den = 0.0
    used = 0
    for s in segs:
        if s.step is None or s.load not in fr:
            continue
        b, tc = fr[s.load]
        a_i, a_w, a_n, dw, a_rest = s.step
        # the shaft at rest: friction holds what the current drives (no motion, no impulse)
        impulse = a_i - a_rest - b * a_w - tc * a_n
        num += dw * impulse
        den += dw * dw
        used += 1
    return (num / den if den > 0 else float("nan")), used


def _la(recs, ws, ra, ke, masks) -> tuple[float, list]:
    """La (H) from the voltage balance by the instrument, and its per-segment sums (zy, zx)."""
    sums = []
    for rec, w, m in zip(recs, ws, masks):
        df = rec.df
        T = float(np.median(dataset.dt_s(rec)[1:]))
        v, i = df["v_V"].to_numpy(float), df["i_A"].to_numpy(float)
        y = v - ra * i - ke * w
        x = np.full(rec.n, np.nan)
        z = np.full(rec.n, np.nan)
        x[1:] = (i[1:] - i[:-1]) / T
        z[2:-1] = (i[3:] - i[:-3]) / T
        seg = _segments(rec)
        ok = np.isfinite(x) & np.isfinite(z) & np.isfinite(y) & m
        # the stencil must not cross a restart of the clock (a gap in seq)
        ok[dataset.segment_starts(rec)] = False
        for sid in np.unique(seg[ok]):
            k = ok & (seg == sid)
            # the step into a segment sits at its first rows: a segment's sums hold its own step
            sums.append((float(np.sum(z[k] * y[k])), float(np.sum(z[k] * x[k]))))
    zy = sum(a for a, _ in sums)
    zx = sum(b for _, b in sums)
    return (zy / zx if zx != 0 else float("nan")), sums


def _lag(recs, ws) -> list:
    """The time (s) for the speed to cover 63 % of each duty step (the row means, interpolated)."""
    out = []
    for rec, w in zip(recs, ws):
        T = float(np.median(dataset.dt_s(rec)[1:]))
        seg = _segments(rec)
        starts = np.flatnonzero(np.r_[False, np.diff(seg) != 0])
        n_settle, n_avg = int(round(SETTLE_S / T)), max(1, int(round(AVG_S / T)))
        for s in starts:
            if s < n_avg or s + n_settle + n_avg > rec.n:
                continue
            w0 = np.mean(w[s - n_avg:s])
            w1 = np.mean(w[s + n_settle:s + n_settle + n_avg])
            if not (np.isfinite(w0) and np.isfinite(w1)) or abs(w1 - w0) < MIN_STEP_RAD_S or w0 < MIN_W_RAD_S:
                continue
            frac = (w[s:s + n_settle] - w0) / (w1 - w0)
            if not np.isfinite(frac).all():
                continue
            target = 1.0 - math.exp(-1.0)
            k = int(np.argmax(frac >= target))
            if frac[k] < target:
                continue
            f0 = frac[k - 1] if k > 0 else 0.0
            # a row's mean sits at its middle: the row k's crossing, interpolated between row middles
            out.append(T * (k - 0.5 + (target - f0) / max(frac[k] - f0, 1e-9)) + 0.5 * T if k > 0 else 0.5 * T)
    return out


def _interval(field: str, value: float, boot: np.ndarray, why_not: str = "", clusters: int = 0) -> Interval:
    d = schema.DYN_BY_FIELD.get(field)
    if d is not None:
        name, unit, scale, show_unit, phys, needs = field, d.unit, d.show_scale, d.show_unit, d.physical, NEEDS
        name = {"j_kgm2": "J", "b_nms_per_rad": "B", "tc_nm": "Tc"}.get(field, field)
    else:
        e = schema.BY_NAME[schema.DYNAMICS_INDUCTANCE]
        name, unit, scale, show_unit, phys, needs = "La", e.unit, e.show_scale, e.show_unit, e.physical, LA_NEEDS
    boot = boot[np.isfinite(boot)]
    # an undetermined quantity keeps its fitted value only where the quantity can take it: a negative inductance
    # (a fuzzing helper's metrics.json) is no value of La
    fitted = float(value) if np.isfinite(value) and phys[0] <= value <= phys[1] else None
    if why_not or not np.isfinite(value) or len(boot) < BOOT // 2:
        return Interval(name, field, unit, fitted, None, None, False,
                        why=why_not or "too few steps or segments hold it", needs=needs, method="bootstrap",
                        show_scale=scale, show_unit=show_unit)
    # the bootstrap's standard error with Student's t on (clusters - 1) degrees of freedom: with a handful of
    # steps the percentile interval is too narrow (on the twin's sweep it held the true J in 9 of 12 seeds)
    half = float(stats.t.ppf((1 + LEVEL) / 2, max(clusters - 1, 1))) * float(np.std(boot, ddof=1))
    lo, hi = value - half, value + half
    ok = phys[0] <= lo and hi <= phys[1]
    why = "" if ok else (f"its interval {lo * scale:.3g}..{hi * scale:.3g} {show_unit} reaches outside the physical "
                         f"{phys[0] * scale:.3g}..{phys[1] * scale:.3g} {show_unit}")
    if fitted is None:
        return Interval(name, field, unit, None, None, None, False, why=why, needs=needs, clusters=clusters,
                        method="bootstrap over whole segments, Student's t", show_scale=scale, show_unit=show_unit)
    return Interval(name, field, unit, float(value), lo, hi, ok, why=why, needs="" if ok else needs,
                    clusters=clusters, method="bootstrap over whole segments, Student's t", show_scale=scale, show_unit=show_unit)


def _slower_than_the_windows(iv: Interval, lag_s: float) -> Interval:
    """iv not determined where the shaft's measured lag (63 % of a step, about its mechanical time constant)
    leaves the transient unfinished where the estimate takes it as over: J's impulse ends STEP_SPAN_S after the
    step (at least 3 lags, 5 % of the step left), the friction's settled rows start SETTLE_S after it (at least
    5 lags). A fuzzing round's 500 Hz bench with a 50 ms shaft had J 8 % low with an interval of 0.2 %."""
    limit = {"j_kgm2": STEP_SPAN_S / 3.0, "b_nms_per_rad": SETTLE_S / 5.0, "tc_nm": SETTLE_S / 5.0}.get(iv.field)
    if limit is None or lag_s <= limit or not iv.determined:
        return iv
    span = STEP_SPAN_S if iv.field == "j_kgm2" else SETTLE_S
    return dataclasses.replace(iv, lo=None, hi=None, determined=False, needs=NEEDS,
                               why=(f"the speed lags the duty steps by {1e3 * lag_s:.0f} ms, so it is still moving "
                                    f"{1e3 * span:.0f} ms after a step, where the estimate takes it as settled: "
                                    f"the estimate needs the shaft's lag under {1e3 * limit:.0f} ms"))


def _scaled_by_kt(iv: Interval, rel: float, given: str) -> Interval:
    """iv (J, B or Tc: each scales with the torque constant) with the torque constant's relative
    expanded half-width rel joined in quadrature (GUM: both parts at 95 %), its budget split in
    the two parts, and given saying what it is conditional on; not determined where Kt is not."""
    if not given:
        return iv
    if not iv.determined or iv.value is None:
        return dataclasses.replace(iv, given=given)
    if not math.isfinite(rel):
        return dataclasses.replace(iv, lo=None, hi=None, determined=False, given=given,
                                   why="the torque constant it scales with (Kt = Ke) is not determined", needs=NEEDS)
    half_boot = max(iv.hi - iv.value, iv.value - iv.lo)
    half_kt = abs(iv.value) * rel
    half = math.hypot(half_boot, half_kt)
    lo, hi = iv.value - half, iv.value + half
    d = schema.DYN_BY_FIELD[iv.field]
    ok = d.physical[0] <= lo and hi <= d.physical[1]
    why = "" if ok else (f"its interval {lo * d.show_scale:.3g}..{hi * d.show_scale:.3g} {d.show_unit} reaches outside "
                         f"the physical {d.physical[0] * d.show_scale:.3g}..{d.physical[1] * d.show_scale:.3g} {d.show_unit}")
    if not ok:
        return dataclasses.replace(iv, lo=None, hi=None, determined=False, given=given, why=why, needs=NEEDS)
    k = 1.96  # the parts as standard uncertainties, each expanded half-width over its coverage factor
    return dataclasses.replace(iv, lo=lo, hi=hi, given=given,
                               budget={"statistical": half_boot / k, "Kt": half_kt / k, "expanded": half})


def identify(recs, ra_ohm: float, ke_vs_per_rad: float, est_rpm=None, la_given_H: float = 0.0,
             kt: Interval | None = None) -> Dynamics:
    """The dynamic family from the recordings at MIN_RATE_HZ and up (the training rows only),
    and, given est_rpm (the model under test's speed per row of each recording), the held-out
    RMSE before and after the observer. kt: the torque constant (Kt = Ke in SI) as the caller
    determined it, with its interval (the diagnosis' Ke, whose budget holds the doubt of the Ra
    held); J, B and Tc scale with it, so their intervals take its relative half-width in quadrature
    and say they are given it. None: ke_vs_per_rad, taken as exact."""
    rates = [1.0 / float(np.median(dataset.dt_s(r)[1:])) if r.n > 2 else 0.0 for r in recs]
    steady = [dataset.kind(r)[0] == "steady_state" for r in recs]
    fast = [k for k, (rt, st) in enumerate(zip(rates, steady)) if rt >= MIN_RATE_HZ and not st]
    top = max(rates) if rates else 0.0
    if not fast:
        return Dynamics(rate_hz=top, fast=[], speed_from="")
    recs_f = [recs[k] for k in fast]
    speeds = [speed_rad_s(r) for r in recs_f]
    ws = [w for w, _ in speeds]
    speed_from = speeds[0][1] if len({s for _, s in speeds}) == 1 else "encoder periods and the rpm_ref column"
    kt_rel, kt_given = 0.0, ""
    if kt is not None and kt.value is not None and math.isfinite(kt.value) and kt.value > 0:
        kt_rel = (max(kt.hi - kt.value, kt.value - kt.lo) / kt.value if kt.determined and kt.lo is not None
                  else math.inf)
        kt_given = (f"Kt = Ke = {kt.value:.4g} V s/rad" + (f", within {100 * kt_rel:.2g} % (its interval)"
                                                           if math.isfinite(kt_rel) else ", not determined"))
        kt = float(kt.value)
    else:
        kt = ke_vs_per_rad
    train = [np.arange(r.n) < r.n_train for r in recs_f]
    segs = []
    for ri, (r, w, m) in enumerate(zip(recs_f, ws, train)):
        T = float(np.median(dataset.dt_s(r)[1:]))
        segs += _summaries(r, w, kt, T, m, ri)
    fr = _friction(segs)
    J, used = _inertia(segs, fr)
    la, la_sums = _la(recs_f, ws, ra_ohm, ke_vs_per_rad, train)
    # the bootstrap over whole segments
    rng = np.random.default_rng(SEED)
    bj, bb, btc, bla = (np.full(BOOT, np.nan) for _ in range(4))
    for b in range(BOOT):
        draw = [segs[k] for k in rng.integers(0, len(segs), len(segs))]
        f = _friction(draw)
        bj[b] = _inertia(draw, f)[0]
        if 0 in f:
            bb[b], btc[b] = f[0]
        if la_sums:
            pick = rng.integers(0, len(la_sums), len(la_sums))
            zx = sum(la_sums[k][1] for k in pick)
            bla[b] = sum(la_sums[k][0] for k in pick) / zx if zx != 0 else np.nan
    n_settled = sum(s.settled is not None for s in segs)
    no_free = "" if 0 in fr else ("no segment at load state 0 (no external load) with two settled speeds: the "
                                  "friction is not known apart from the load's torque")
    free = sum(sg.settled is not None and sg.load == 0 for sg in segs)
    q = [_interval("j_kgm2", J, bj, "" if used >= 2 else f"{used} usable duty step(s) (two or more needed)", used),
         _interval("b_nms_per_rad", fr.get(0, (np.nan, np.nan))[0], bb, no_free, free),
         _interval("tc_nm", fr.get(0, (np.nan, np.nan))[1], btc, no_free, free),
         _interval("la_H", la, bla, ("" if top >= LA_MIN_RATE_HZ else
                   f"at {top:.4g} Hz the current's rise after a step (La / R, about a ms) is over within a row, "
                   "so the row means hold La di/dt only as the step row's mean, not as the rows' rate of change"), len(la_sums))]
    q = [_scaled_by_kt(iv, kt_rel, kt_given) if iv.field != "la_H" else iv for iv in q]
    lags = _lag(recs_f, ws)
    q = [_slower_than_the_windows(iv, float(np.median(lags))) if lags else iv for iv in q]
    out = Dynamics(rate_hz=top, fast=[r.name for r in recs_f], speed_from=speed_from, steps=used,
                   segments=n_settled, quantities=q,
                   lag_s=float(np.median(lags)) if lags else None,
                   lag_range_s=(float(min(lags)), float(max(lags))) if lags else None)
    if est_rpm is not None and q[0].determined:
        _held_out(out, recs_f, [est_rpm[k] for k in fast], ws, fr, J, kt,
                  la if q[3].determined else 0.0, la_given_H)
    return out


def _held_out(out: Dynamics, recs, ests, ws, fr, J, kt, la_H, la_given_H) -> None:
    """The held-out RMSE before and after the observer, the observer's tau chosen on training rows."""
    b, tc = fr.get(0, next(iter(fr.values())) if fr else (0.0, 0.0))
    meas = []
    for r, est in zip(recs, ests):
        T = float(np.median(dataset.dt_s(r)[1:]))
        i = r.df["i_A"].to_numpy(float)
        extra = np.zeros(r.n)
        if la_H > 0:  # the inductance the model under test does not carry yet
            extra[1:] = -(la_H - la_given_H) * np.diff(i) / T / kt * RPM_PER_RAD_S
        meas.append((np.asarray(est, float) + extra, i, T))

    def rmse(which, tau):
        se = cnt = 0.0
        for (m, i, T), w, r in zip(meas, ws, recs):
            ref = w * RPM_PER_RAD_S
            if tau is None:
                est = m
            else:
                d = dynamics_ref.dynamics_params(j_kgm2=J, b_nms_per_rad=max(b, 0.0), tc_nm=max(tc, 0.0),
                                                 tau_obs_s=tau)
                est = dynamics_ref.run(kt, d, i, np.where(np.isfinite(m), m, np.nan), T)[0].astype(float)
            idx = np.arange(r.n)
            k = ((idx < r.n_train) if which == "train" else (idx >= r.n_train)) & np.isfinite(ref) & np.isfinite(est)
            se += float(np.sum((est[k] - ref[k]) ** 2))
            cnt += int(k.sum())
        return math.sqrt(se / cnt) if cnt else float("nan")

    tau = min(TAU_OBS_GRID_S, key=lambda t: rmse("train", t))
    out.tau_obs_s = tau
    out.rmse_before = rmse("test", None)
    out.rmse_after = rmse("test", tau)
    out.reference = "speed from the " + out.speed_from
