"""The ripple beside an encoder on the output shaft: the ripples per output revolution measured
and the gear ratio checked (`check_ratio`), and the encoder speed a span's count is compared
with (`span_reference`)."""
from __future__ import annotations

import math

import numpy as np

from .options import Options


TRIM = 0.05  # check_ratio: a window's own ripples per encoder revolution this far from the median is left out


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
    ref = np.abs(np.asarray(rpm_ref, float))  # the ripple counts a speed, not its direction: a reversed shaft's too
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
