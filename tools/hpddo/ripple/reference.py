"""The speed measurement that identification, training, diagnosis and scoring take as
`rpm_ref` (issue 23 item 4, docs/ripple-training.md), chosen in this one place.

* "encoder" (the default): the log's own rpm_ref column, as it is.
* "ripple": the speed counted from the commutation ripple in the current bursts beside each
  log (`<condition>.ripple.csv`; hpddo.ripple.log), the encoder's column set aside. A row
  takes the ripple speed where the count is confident; elsewhere its rpm_ref is NaN, so the
  row drives the replay (the observer's lags run through it) but no fit or score uses it,
  and it is counted by its reason (coasting, floor, few_cycles, not_found, far, ambiguous,
  changing; no_burst: a row with no burst). Every step downstream already leaves NaN
  references out (identify, effects, the residual network, the lookup baseline, the
  metrics).

The confidence of each kept row is returned as its weight (Recording.weight), and weights
that row in M2's Ke (eq. 20 as a weighted mean, least squares as weighted least squares) and
in the effect fits (effects.fit, the diagnosis included) and in M3's training (its squared loss,
train.labelled_rows, network.train). The rows without a confident speed are left out
(WEIGHTS_NOTE). Where one window holds too few ripple cycles (a slow shaft), the ripple is
counted over a span of steady windows (spans.count_steady_spans). Where the drive is off, no
current flows and the terminal voltage (then the back-EMF) is under a few mV, the shaft stands:
those rows take 0 RPM from the back-EMF with stall.STANDING_CONFIDENCE (stall.standing), counted
as `standing_labelled`; the other coasting rows are left out. Where the drive is on and current
flows but the shaft stands (stall.count_stalls: no ripple line over a span, a prior too low for a
count), the rows take 0 RPM weighted by the stall's confidence, counted as `stall_labelled`.
"""
from __future__ import annotations

import dataclasses
import math
import pathlib

import numpy as np

from ..logs.ripple import path_for
from .log import ra_of, speed_of_bench, speed_of_log
from .options import Options
from .prior import ModelPrior
from .stall import STANDING_CONFIDENCE, standing

REFERENCES = ("encoder", "ripple")
NO_BURST = "no_burst"
ENCODER_META = ("encoder_counts_per_rev", "encoder_window_s")  # docs/bench-log.md: the encoder's resolution
WEIGHTS_NOTE = ("the ripple's confidence weights each kept row in Ke (eq. 20 or least squares), the effect "
                "fits and M3's training loss; rows without a confident ripple speed are left out")


@dataclasses.dataclass(frozen=True)
class Ripple:
    """The ripple as the reference: the user's ripples per motor revolution and gear ratio,
    and optionally the prior's Ke (else calibrated from the ripple), the current floor and Ra
    (else the log's ra_ohm metadata), or instead of Ke and Ra a trained model's M2 with its named
    effects as the prior (model: prior.ModelPrior, as hpddo ripple --model takes it)."""

    ripples_per_rev: int
    gear_ratio: float
    ke_vs_per_rad: float | None = None
    floor_A: float | None = None
    ra_ohm: float | None = None
    model: ModelPrior | None = None

    # each log's count where the reference was counted over a run's logs (over): ((resolved path, speed_of_log's
    # (estimate, Ke, where Ke came from)), ...)
    counted: tuple = dataclasses.field(default=(), compare=False, repr=False)

    def over(self, paths, logs=None) -> "Ripple":
        """This reference with the ripple of the logs at paths counted as one motor's (speed_of_bench: the figure
        given checked over all of them, so that a log whose windows show no rotation comb is checked by the
        others'), each log's count then taken from there (swap); itself where every path is counted already.
        logs: the logs at paths as benchlog.read_log gave them, where the caller has read them already (counted
        from copies of their frames: the recordings are made from them afterwards)."""
        from ..logs import benchlog

        done = {k for k, _ in self.counted}
        paths = [pathlib.Path(p) for p in paths]
        if all(str(p.resolve()) in done for p in paths):
            return self
        read = [benchlog.read_log(p) for p in paths] if logs is None else logs
        logs = [(p, log.df.copy(), dict(log.meta), None) for p, log in zip(paths, read)]
        got = speed_of_bench(logs, self.options(), self.ra_ohm, self.ke_vs_per_rad, model=self.model)
        return dataclasses.replace(self, counted=tuple((str(p.resolve()), r) for p, r in zip(paths, got)))

    def options(self) -> Options:
        o = Options(self.ripples_per_rev, self.gear_ratio)
        return o if self.floor_A is None else dataclasses.replace(o, floor_A=self.floor_A)

    def __call__(self, path, df, meta):
        """The swap for one log (hpddo.logs.dataset.load_recording calls it before the glitch
        filter): (df with rpm_ref the confident ripple speed and NaN elsewhere, meta without
        the encoder's resolution (ENCODER_META: it no longer describes rpm_ref), per-row weight
        (the confidence; 0 where left out), record for metrics.json / diagnosis.json)."""
        return swap(path, df, meta, self)

    def to_json(self) -> dict:
        return {"reference": "ripple", "ripples_per_rev": self.ripples_per_rev, "gear_ratio": self.gear_ratio,
                "ke_vs_per_rad": self.ke_vs_per_rad, "floor_A": self.options().floor_A,
                "prior_model": None if self.model is None else self.model.to_json()}


def direction(df, ra_ohm: float, standing_V: float = Options.standing_V) -> np.ndarray:
    """Each row's direction of rotation, +1 or -1: the terminal voltage's sign where it shows (|V| of standing_V or
    more: the drive's polarity, or the open terminals' back-EMF; an Ra a little off near a stall does not turn it),
    else the back-EMF V - I Ra's where Ra is known (ra_ohm: log.ra_of's, NaN or not > 0 where it is not); +1 where
    neither says (a shaft at rest: 0 either way)."""
    v = df["v_V"].to_numpy(float)
    emf = v - df["i_A"].to_numpy(float) * ra_ohm if math.isfinite(ra_ohm) and ra_ohm > 0 else v
    return np.where(np.abs(v) >= standing_V, np.where(v < 0.0, -1.0, 1.0), np.where(emf < 0.0, -1.0, 1.0))


def swap(path, df, meta: dict, ref: Ripple):
    """See Ripple.__call__."""
    got = dict(ref.counted).get(str(pathlib.Path(path).resolve()))
    est, ke, ke_from = got if got is not None else speed_of_log(path, df, meta, ref.options(), ref.ra_ohm,
                                                                 ref.ke_vs_per_rad, model=ref.model)
    n = len(df)
    rpm = np.full(n, np.nan)
    weight = np.zeros(n)
    key = np.full(n, NO_BURST, dtype=object)
    rows = est["row"].to_numpy()
    conf = est["confident"].to_numpy()
    rpm[rows[conf]] = est["rpm"].to_numpy()[conf]
    weight[rows[conf]] = est["confidence"].to_numpy()[conf]
    key[rows] = est["key"].to_numpy()
    # the rows where the shaft stands by the back-EMF (drive off, no current, |V| under the
    # threshold): 0 RPM, a measurement where the ripple has nothing to count (stall.standing)
    still = standing(est, df["duty"].to_numpy()[rows], df["v_V"].to_numpy()[rows], ref.options())
    rpm[rows[still]] = 0.0
    weight[rows[still]] = STANDING_CONFIDENCE
    # a stall (stall.count_stalls: the drive on, current flowing, no ripple over a span and a prior too low
    # for a count): 0 RPM, weighted by its confidence (1 - bound / (2 stall_max_rpm)), as the encoder of a
    # jammed shaft reads it; at 0 RPM identification leaves it out (identify.MIN_RPM), the effect fits and M3 take it
    stall = est["stall"].to_numpy(bool)
    rpm[rows[stall]] = 0.0
    weight[rows[stall]] = est["confidence"].to_numpy(float)[stall]
    # the ripple counts a speed, not its direction: the back-EMF's sign gives it (V - I Ra; V alone without Ra, the
    # drive's polarity), so a reversed shaft is labelled as its encoder would label it, not as one turning forward
    rpm = rpm * direction(df, ra_of(meta, ref.ra_ohm)) + 0.0  # (+ 0.0: no -0.0)
    kept = np.isfinite(rpm)
    out = df.copy()
    had_encoder = "rpm_ref" in out and bool(np.isfinite(out["rpm_ref"].to_numpy(float)).any())
    out["rpm_ref"] = rpm
    left = {k: int(c) for k, c in zip(*np.unique(key[~kept].astype(str), return_counts=True))}
    w = weight[kept]
    record = {**ref.to_json(), "bursts": path_for(path).name,
              "ke_prior_vs_per_rad": ke if math.isfinite(ke) else None, "ke_from": ke_from, "rows": n, "kept": int(kept.sum()),
              "standing_labelled": int(still.sum()), "standing_V": ref.options().standing_V,
              "stall_labelled": int(stall.sum()),
              "left_out": int((~kept).sum()), "left_out_by_reason": left,
              "confidence_kept": {"min": float(w.min()), "median": float(np.median(w))} if w.size else None,
              "encoder_set_aside": had_encoder}
    meta = {k: v for k, v in meta.items() if k not in ENCODER_META}
    return out, meta, weight, record


def pooled(records: dict) -> dict | None:
    """{recording name: record} of a run pooled, as metrics.json and diagnosis.json carry it
    under "reference": the settings, the rows kept and left out (by reason) over all, the note
    on weights, and each recording's record; None where no recording has one (the encoder)."""
    records = {k: v for k, v in records.items() if v is not None}
    if not records:
        return None
    left: dict = {}
    for r in records.values():
        for k, c in r["left_out_by_reason"].items():
            left[k] = left.get(k, 0) + c
    first = next(iter(records.values()))
    return {**{k: first[k] for k in ("reference", "ripples_per_rev", "gear_ratio", "ke_vs_per_rad", "floor_A",
                                          "prior_model")},
            "rows": sum(r["rows"] for r in records.values()), "kept": sum(r["kept"] for r in records.values()),
            "standing_labelled": sum(r.get("standing_labelled", 0) for r in records.values()),
            "stall_labelled": sum(r.get("stall_labelled", 0) for r in records.values()),
            "left_out": sum(r["left_out"] for r in records.values()), "left_out_by_reason": dict(sorted(left.items())),
            "weights": WEIGHTS_NOTE, "recordings": records}


def line(name: str, record: dict) -> str:
    """One printed line: where the reference came from and the rows left out, by reason."""
    why = ", ".join(f"{k} {c}" for k, c in sorted(record["left_out_by_reason"].items()))
    ke = record.get("ke_prior_vs_per_rad")
    prior = (f"prior Ke {ke:.4f} V s/rad from {record['ke_from']}" if ke is not None and math.isfinite(ke)
             else f"no back-EMF prior ({record['ke_from']})")
    return (f"{name}: reference ripple ({record['ripples_per_rev']} x {record['gear_ratio']:g} per output "
            f"revolution, {prior}): "
            f"{record['kept']} of {record['rows']} rows kept"
            + (f" ({record['standing_labelled']} of them standing: 0 RPM from the back-EMF, drive off, no "
               f"current, |V| < {1000 * record['standing_V']:g} mV)" if record.get("standing_labelled") else "")
            + (f" ({record['stall_labelled']} of them a stall: 0 RPM, the drive on, no ripple over a span)"
               if record.get("stall_labelled") else "")
            + f", {record['left_out']} left out"
            + (f" ({why})" if why else ""))
