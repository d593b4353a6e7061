"""Identification of the physics models from the training rows.

M1: the nameplate Ke (rated voltage over rated no-load speed), the measured Ra.
M2: the measured Ra and Ke from steady-state rows (rpm_ref > 10), by the paper's eq. 20
(the mean of the per-row ratio) or by least squares; plus the coefficients of any named
effects (effects.py), fitted on the same rows.
"""
from __future__ import annotations

import math

import numpy as np

from . import physics as ph
from ..logs.dataset import Recording, kind
from ..logs.errors import InputError

RAD_S_PER_RPM = 2.0 * np.pi / 60.0  # the paper's 0.10472
MIN_RPM = 10.0  # eq. 20 uses rows above 10 RPM: below, stiction and encoder quantisation rule
# Ke is identified on means over consecutive windows of this length (one row at the
# paper's 2 Hz). V, I and speed are means over each sample period and the back-EMF
# relation is linear in them, so window means obey it too, while an encoder that moves
# in steps of 310 RPM at 1 kHz averages out to a fraction of an RPM.
IDENT_WINDOW_S = 0.5


class IdentificationError(InputError):
    pass


def ra_from_logs(recs: list[Recording], ra_option: float | None) -> tuple[float, str]:
    """Ra from the option, else from the logs' ra_ohm metadata (all must agree)."""
    if ra_option is not None:
        if not (math.isfinite(ra_option) and ra_option > 0):
            raise IdentificationError(f"--ra-ohm must be a positive resistance in ohm, got {ra_option}")
        return float(ra_option), "option --ra-ohm"
    values = {}
    for r in recs:
        if "ra_ohm" in r.meta:
            try:
                values[r.source.name] = float(r.meta["ra_ohm"])
            except ValueError:
                raise IdentificationError(f"{r.source}: metadata ra_ohm={r.meta['ra_ohm']!r} is not a number") from None
            if not (math.isfinite(values[r.source.name]) and values[r.source.name] > 0):
                raise IdentificationError(f"{r.source}: metadata ra_ohm={r.meta['ra_ohm']!r} is not a positive "
                                          "resistance; correct it, or give --ra-ohm")
    if not values:
        raise IdentificationError("no Ra: give --ra-ohm (a multimeter reading) or ra_ohm= metadata in the logs")
    distinct = set(values.values())
    if len(distinct) > 1:
        raise IdentificationError(f"the logs disagree on ra_ohm: {values}; give --ra-ohm")
    ra = distinct.pop()
    if not ra > 0:
        raise IdentificationError(f"ra_ohm must be positive, got {ra}")
    return ra, "log metadata ra_ohm"


# The log metadata that says at which temperature ra_ohm was read (docs/bench-log.md, Known keys).
RA_TEMP_KEY = "ra_temp_C"


def declared_ra_temp_C(recs: list[Recording]) -> float | None:
    """The temperature at which the logs' Ra was read (metadata ra_temp_C), None where no log declares it;
    refused where it is not a temperature the case sensor could read or the logs disagree."""
    from ..logs.dataset import TEMP_RANGE_C
    values = {}
    for r in recs:
        if RA_TEMP_KEY not in r.meta:
            continue
        text = r.meta[RA_TEMP_KEY]
        try:
            t = float(text)
        except ValueError:
            t = float("nan")
        if not (math.isfinite(t) and TEMP_RANGE_C[0] <= t <= TEMP_RANGE_C[1]):
            raise IdentificationError(f"{r.source}: metadata {RA_TEMP_KEY}={text!r} is not a temperature in C within "
                                      f"{TEMP_RANGE_C[0]:g}..{TEMP_RANGE_C[1]:g} (the one at which ra_ohm was read)")
        values[r.source.name] = t
    if len(set(values.values())) > 1:
        raise IdentificationError(f"the logs disagree on {RA_TEMP_KEY} (the temperature Ra was read at): {values}")
    return next(iter(values.values()), None)


def first_temp_C(recs: list[Recording]) -> float | None:
    """The first temperature reading of the first recording that has one, None without."""
    for r in recs:
        if r.has_temp():
            return float(r.df["temp_C"].dropna().iloc[0])
    return None


def reference_temp_C(recs: list[Recording]) -> float:
    """Temperature at which Ra was measured: the logs' ra_temp_C where they declare it, else the
    first reading of the first recording that has one (the motor cold, as on the bench), else 25 C.
    A reading taken on a warm motor (a log that starts hot) needs the declaration: the copper's
    0.393 %/K over 24 K is 9 % of Ra."""
    declared = declared_ra_temp_C(recs)
    if declared is not None:
        return declared
    first = first_temp_C(recs)
    return 25.0 if first is None else first


def ambient_C(recs: list[Recording]) -> float:
    """The temperature where none is read (the thermal node's start): the first reading, else the
    temperature Ra was read at (reference_temp_C)."""
    first = first_temp_C(recs)
    return reference_temp_C(recs) if first is None else first


def ke_eq20(v_V, i_A, rpm_ref, ra_ohm, weight=None) -> float:
    """Paper eq. 20: mean over rows of (V - I Ra) / (rpm_ref * 2 pi / 60); with a weight per
    row (the ripple reference's confidence), the weighted mean."""
    ratio = (v_V - i_A * ra_ohm) / (rpm_ref * RAD_S_PER_RPM)
    return float(np.mean(ratio) if weight is None else np.average(ratio, weights=weight))


def ke_lsq(v_V, i_A, rpm_ref, ra_ohm, weight=None) -> float:
    """Least squares: minimises sum weight (V - I Ra - Ke w)^2 over rows (weight 1 unless given)."""
    w = rpm_ref * RAD_S_PER_RPM
    c = np.ones_like(w) if weight is None else np.asarray(weight, float)
    return float(np.sum(c * (v_V - i_A * ra_ohm) * w) / np.sum(c * w * w))


def steady_rows(recs: list[Recording]):
    """(v, i, rpm_ref, weight) of the training rows with rpm_ref > MIN_RPM, pooled; weight is
    None unless a recording's reference carries a confidence per row (Recording.weight: the
    ripple), then each row's (1 for a recording without one)."""
    return ke_rows(recs)[:4]


def ke_rows(recs: list[Recording]):
    """steady_rows and, fifth, each row's operating group (a number per recording and run of one
    duty): the rows every Ke of M2 is identified on (hpddo train, and the diagnosis' check of
    eq. 20 against least squares, clustered by the groups)."""
    labelled = [r for r in recs if "rpm_ref" in r.df]
    if not labelled:
        raise IdentificationError(
            f"no recording has an rpm_ref column (encoder speed): {', '.join(str(r.source) for r in recs)}; "
            "identifying M2 and training M3 need at least one labelled recording")
    weighted = any(r.weight is not None for r in labelled)
    parts = [window_means(r.part("train"), weight=(None if not weighted else
                                                   np.ones(r.n_train) if r.weight is None else r.weight[:r.n_train]),
                          cols=("v_V", "i_A", "rpm_ref", "duty"), settled=kind(r)[0] == "steady_state")
             for r in labelled]
    v = np.concatenate([p[0] for p in parts])
    i = np.concatenate([p[1] for p in parts])
    n = np.concatenate([p[2] for p in parts])
    w = np.concatenate([p[4] for p in parts]) if weighted else None
    group, base = [], 0
    for p in parts:  # a new group wherever the (windowed) duty changes, numbered on across recordings
        duty = p[3]
        g = base + np.concatenate([[0], np.cumsum(np.abs(np.diff(duty)) > 1e-9)]) if len(duty) else np.zeros(0)
        group.append(g)
        base = int(g.max()) + 1 if len(g) else base
    group = np.concatenate(group)
    keep = np.isfinite(n) & (n > MIN_RPM)
    if keep.sum() < 5:
        turning = sum(int((np.nan_to_num(r.part("train")["rpm_ref"].to_numpy(float)) > MIN_RPM).sum()) for r in labelled)
        if turning >= 5:  # the rows are there, their windows are not: a time series shorter than a few windows
            raise IdentificationError(
                f"only {int(keep.sum())} training window(s) with rpm_ref > {MIN_RPM} RPM in "
                f"{', '.join(str(r.source) for r in labelled)} ({turning} turning rows, averaged over windows of "
                f"{IDENT_WINDOW_S:g} s of t_s as a time series' are): M2 needs at least 5; record longer, or, for a "
                "table of settled points, declare # kind=steady_state (docs/bench-log.md)")
        raise IdentificationError(f"only {int(keep.sum())} training rows with rpm_ref > {MIN_RPM} RPM in "
                                  f"{', '.join(str(r.source) for r in labelled)}: M2 needs a labelled recording "
                                  "of the motor turning")
    return v[keep], i[keep], n[keep], (None if w is None else w[keep]), group[keep]


def window_means(part, window_s: float = IDENT_WINDOW_S, weight=None, cols=("v_V", "i_A", "rpm_ref"),
                 settled: bool = False):
    """(v, i, rpm_ref) (the columns cols) of a recording part as means over consecutive windows
    of about window_s (rows with no rpm_ref left out); at 2 Hz and slower, the rows themselves, and
    so for a table of settled points (settled: its t_s is no clock, whatever its steps); a window
    holds the part's rows at the most. With a weight per row of the part, the weight last, meaned
    as the rest."""
    t = part["t_s"].to_numpy(float)
    keep = np.isfinite(part["rpm_ref"].to_numpy(float))
    cols = [part[c].to_numpy(float)[keep] for c in cols]
    if weight is not None:
        cols.append(np.asarray(weight, float)[keep])
    if settled:
        return cols
    dt = float(np.median(np.diff(t))) if len(t) > 1 else window_s
    k = int(min(max(1.0, round(window_s / dt)), max(len(cols[0]), 1))) if dt > 0 else 1
    if k == 1:
        return cols
    m = len(cols[0]) // k
    return [c[: m * k].reshape(m, k).mean(axis=1) for c in cols]


def check_ke(ke: float, v, i, ra_ohm: float, ra_source: str = "") -> None:
    """Raises IdentificationError naming the likely cause when Ke is not positive."""
    if ke > 0:
        return
    emf = v - i * ra_ohm
    neg = float(np.mean(emf <= 0))
    turning = i > 0.02
    if neg > 0.5 and turning.any():
        ra_max = float(np.percentile(v[turning] / i[turning], 5))
        raise IdentificationError(
            f"identified Ke = {ke:.4g} V s/rad is not positive: V - I*Ra is negative on {100 * neg:.0f} % of the "
            f"turning rows, so Ra = {ra_ohm:.4g} ohm ({ra_source or 'given'}) is too large for these recordings "
            f"(V/I on the turning rows is {ra_max:.3g} ohm or more at the 5th percentile; a running motor has "
            "Ra well below V/I): check --ra-ohm or the logs' ra_ohm metadata")
    raise IdentificationError(f"identified Ke = {ke:.4g} V s/rad is not positive: check the V and I channels "
                              "(sign, gain) and the rpm_ref column")


# How M2's Ke is identified (hpddo train and diagnose --ke-fit): the paper's eq. 20 (mean of the
# per-window ratios (V - I Ra) / w) or least squares of V - I Ra on w.
KE_FITS = ("eq20", "lsq")


def m2_params(recs: list[Recording], ra_ohm: float, ke_fit: str = "eq20") -> ph.PhysicsParams:
    """Plain M2: measured Ra, identified Ke, no effects."""
    v, i, n, w = steady_rows(recs)
    ke = ke_eq20(v, i, n, ra_ohm, w) if ke_fit == "eq20" else ke_lsq(v, i, n, ra_ohm, w)
    check_ke(ke, v, i, ra_ohm)
    return ph.PhysicsParams(ra_ohm=ra_ohm, ke_vs_per_rad=ke, t_ref_C=reference_temp_C(recs), t_amb_C=ambient_C(recs))
