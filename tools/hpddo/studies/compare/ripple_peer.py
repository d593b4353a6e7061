"""Ripple counting as a peer of the comparison (issue 23 item 6, docs/ripple-compare.md): the speed
counted from the commutation ripple of the current bursts beside each log
(`<condition>.ripple.csv`, hpddo.ripple), given the motor's ripples per revolution and
gear ratio.

* "ripple": alone, as a user without an encoder has it: the back-EMF prior that resolves the
  octave and sub-harmonic ambiguity is (V - I Ra) / Ke with Ke calibrated from the ripple
  itself (no encoder reading used), or the user's Ke (--ke-vs-per-rad), or a trained model's
  M2 with its named effects, its own Ra and Ke (--prior-model, as hpddo ripple --model). A row
  without a confident count has no estimate: its RMSE is over the confident rows, and the
  coverage (the share of rows with an estimate) is reported beside it.
* "ripple + M2": fused with the physics: the prior is the comparison's M2 (Ke from the
  training rows), and a row without a confident count takes M2's estimate, so every row is
  scored.
* "EKF + ripple": the comparison's EKF (tuned as the paper's) with the same count as a second
  measurement of the speed beside the current, weighted by the count's own uncertainty
  (hpddo.ripple.count.count_sd_rpm); every row (host/compare, compare_observers --ripple).

Neither is trained, so the same estimate serves every split (chronological, never seen,
leave one out)."""
from __future__ import annotations

import dataclasses

import numpy as np

from ...logs import benchlog
from ...logs import ripple as ripple_file
from ...logs.errors import InputError
from ...ripple.count import count_sd_rpm
from ...ripple.log import speed_of_bench, speed_of_log
from ...ripple.options import Options
from ...ripple.prior import ModelPrior
from .methods import reference

ALONE = "ripple"
FUSED = "ripple + M2"
EKF = "EKF + ripple"
METHODS = (ALONE, FUSED, EKF)


@dataclasses.dataclass(frozen=True)
class RippleSpeeds:
    """Per cleaned row of one recording: the ripple speed alone and with M2's prior (NaN where
    the count is not confident), the latter's standard uncertainty, and the Ke the alone count's
    prior took and where it came from (hpddo.ripple.log.speed_of_log)."""

    alone_rpm: np.ndarray
    with_m2_prior_rpm: np.ndarray
    ke_alone_vs_per_rad: float
    with_m2_prior_sd_rpm: np.ndarray
    alone_ke_from: str


def has_bursts(rec) -> bool:
    return ripple_file.path_for(rec.source).exists()


def speeds(rec, opts: Options, ra_ohm: float, ke_m2_vs_per_rad: float,
           ke_alone_vs_per_rad: float | None = None, prior_model: ModelPrior | None = None) -> RippleSpeeds:
    """The ripple speeds of one recording counted alone (speeds_of([rec], ...))."""
    return speeds_of([rec], opts, ra_ohm, ke_m2_vs_per_rad, ke_alone_vs_per_rad, prior_model)[rec.name]


def speeds_of(recs, opts: Options, ra_ohm: float, ke_m2_vs_per_rad: float,
              ke_alone_vs_per_rad: float | None = None, prior_model: ModelPrior | None = None) -> dict:
    """{recording name: RippleSpeeds} of recordings of one motor (hpddo.logs.dataset.Recording), each
    counted on the log's own rows (before the glitch filter, as the bursts are) and mapped onto the
    cleaned rows by seq. The alone count takes the recordings together, as `hpddo ripple` takes a run's
    logs (speed_of_bench): with Ke calibrated from the ripple, a recording whose own combs cannot check
    the ripples per revolution given is checked by the others'. ke_alone_vs_per_rad: the alone count's
    prior Ke as the user gives it (None: calibrated from the ripple); prior_model: a trained model's M2
    as the alone count's prior instead, with its own Ra (ra_ohm, the comparison's, stays M2's of the
    fused count)."""
    read = []
    for rec in recs:
        log = benchlog.read_log(rec.source)
        raw = log.df
        if "seq" not in raw:
            raw = raw.assign(seq=np.arange(len(raw), dtype=np.int64))
        read.append((rec, raw, log.meta, ripple_file.read(ripple_file.path_for(rec.source))))  # read once
    alone = speed_of_bench([(rec.source, raw, meta, bursts) for rec, raw, meta, bursts in read], opts,
                           None if prior_model is not None else ra_ohm, ke_alone_vs_per_rad, model=prior_model)
    out = {}
    for (rec, raw, meta, bursts), (est_alone, ke_alone, ke_from) in zip(read, alone):
        row_of = {int(s): k for k, s in enumerate(rec.df["seq"].to_numpy(np.int64))}

        def on_rows(est, values=None) -> np.ndarray:
            v = np.full(rec.n, np.nan)
            seq = raw["seq"].to_numpy(np.int64)[est["row"].to_numpy()]
            conf = est["confident"].to_numpy()
            for s, c, x in zip(seq, conf, est["rpm"].to_numpy(float) if values is None else values):
                k = row_of.get(int(s))
                if c and k is not None:
                    v[k] = x
            return v

        fused, _, _ = speed_of_log(rec.source, raw, meta, opts, ra_ohm, ke_m2_vs_per_rad, bursts)
        out[rec.name] = RippleSpeeds(on_rows(est_alone), on_rows(fused), float(ke_alone),
                                     on_rows(fused, count_sd_rpm(fused)), ke_from)
    return out


def priors(all_speeds: dict) -> dict:
    """{recording: {"ke_prior_vs_per_rad", "ke_from"}}: the alone count's prior on each
    recording, as hpddo ripple's summary.json names it."""
    return {name: {"ke_prior_vs_per_rad": s.ke_alone_vs_per_rad, "ke_from": s.alone_ke_from}
            for name, s in all_speeds.items()}


def estimates(s: RippleSpeeds, m2_rpm: np.ndarray) -> dict:
    """{ALONE: NaN where not confident, FUSED: the ripple where confident, else M2} (EKF comes
    from the observers' replay, run_observers with ripple)."""
    m2_rpm = np.asarray(m2_rpm, float)
    return {ALONE: s.alone_rpm, FUSED: np.where(np.isfinite(s.with_m2_prior_rpm), s.with_m2_prior_rpm, m2_rpm)}


#: tuning the EKF that takes the count: the count is withheld from every other block of this many
#: rows of the training parts, so that the tuned noises also fit the rows without a count (the
#: coasting, slow and changing rows of the test parts), not only a filter that follows the count
TUNING_WITHHELD_BLOCK_ROWS = 10


def write_speeds(s: RippleSpeeds, path, rows: int | None = None, for_tuning: bool = False) -> None:
    """The count with M2's prior and its uncertainty, one line per cleaned row (both fields empty
    where not confident; rows: the first rows only, a recording's training part; for_tuning:
    withheld from every other block of TUNING_WITHHELD_BLOCK_ROWS rows): the second measurement
    of compare_observers --ripple."""
    import pandas as pd
    n = len(s.with_m2_prior_rpm) if rows is None else rows
    rpm, sd = s.with_m2_prior_rpm[:n].copy(), s.with_m2_prior_sd_rpm[:n].copy()
    if for_tuning:
        withheld = (np.arange(n) // TUNING_WITHHELD_BLOCK_ROWS) % 2 == 1
        rpm[withheld] = sd[withheld] = np.nan
    pd.DataFrame({"rpm": rpm, "sd_rpm": sd}).to_csv(path, index=False, float_format="%.10g", na_rep="")


def coverage(recs, all_speeds, masks=None) -> dict:
    """{"ripple_coverage": {recording: share of the scored rows (with an encoder reading)
    that have a confident count, "all": over all}, "ripple_note": the sentence under the
    table}: the rows the alone row's RMSE is taken over."""
    per, n_all, n_kept = {}, 0, 0
    for k, (r, s) in enumerate(zip(recs, all_speeds)):
        ref = reference(r)
        mask = np.isfinite(ref) & (np.ones(r.n, bool) if masks is None else masks[k])
        kept = int(np.sum(mask & np.isfinite(s.alone_rpm)))
        per[r.name] = round(kept / max(int(mask.sum()), 1), 4)
        n_all, n_kept = n_all + int(mask.sum()), n_kept + kept
    cov = {**per, "all": round(n_kept / max(n_all, 1), 4)}
    return {"ripple_coverage": cov, "ripple_note": coverage_note(cov)}


def coverage_note(cov: dict | None) -> str | None:
    """The sentence under a table with ripple rows: the rows the alone row is scored on."""
    if not cov:
        return None
    per = ", ".join(f"{k} {100 * v:.1f} %" for k, v in cov.items() if k != "all")
    return (f"{ALONE}: a confident count on {100 * cov['all']:.1f} % of these rows ({per}); its RMSE is over those "
            f"rows only, '{FUSED}' scores every row (M2 where there is no confident count)")


def check_options(ripples_per_rev, gear_ratio, recs, floor_A: float | None = None,
                  ke_vs_per_rad: float | None = None, prior_model: ModelPrior | None = None) -> Options | None:
    """The ripple options of a comparison: None where not asked for; an InputError where asked
    for and a recording has no bursts beside it, or where only part of them is given."""
    if ripples_per_rev is None and gear_ratio is None:
        if floor_A is not None or ke_vs_per_rad is not None or prior_model is not None:
            raise InputError("--floor-a, --ke-vs-per-rad and --prior-model apply to the ripple peer only: give "
                             "--ripples-per-rev N and --gear-ratio G too (docs/ripple-compare.md)")
        return None
    if ripples_per_rev is None or gear_ratio is None:
        raise InputError("ripple counting as a peer needs both --ripples-per-rev N and --gear-ratio G "
                         "(docs/ripple-compare.md)")
    missing = [str(r.source) for r in recs if not has_bursts(r)]
    if missing:
        raise InputError(f"{missing[0]}: no current bursts beside it ({ripple_file.path_for(missing[0]).name}); "
                         "ripple counting as a peer needs the bursts of every recording (the UNO's ripple mode, or "
                         "hpddo twin --ripple-hz; docs/ripple.md)")
    opts = Options(int(ripples_per_rev), float(gear_ratio))
    return opts if floor_A is None else dataclasses.replace(opts, floor_A=float(floor_A))
