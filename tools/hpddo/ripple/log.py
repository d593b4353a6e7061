"""The ripple speed of every window of a bench log (`speed_of_log`, as `hpddo ripple` counts it):
the bursts beside the log read and matched to its rows, the back-EMF prior, the windows counted
one at a time, over spans, the stalls named and the line's identity over the recording."""
from __future__ import annotations

import math
import pathlib

import numpy as np

from . import sync
from .calibrate import calibrated, ke_evidence, ke_of, placed_only
from .count import count_settled_tails, estimate
from .line import figure_shown, identity_of_recording, prior_checks_figure, unseen_demoted
from .options import Options
from .prior import ModelPrior, m2_prior_rpm, m2_prior_sd_rpm, rpm_per_amp
from .spans import count_steady_spans
from .stall import count_stalls


def number_or_nan(text) -> float:
    """A metadata value as a number; NaN where it is missing or not one."""
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def ra_of(meta: dict, ra_ohm: float | None = None) -> float:
    """The winding's Ra for a log's back-EMF prior: the user's, else the log's ra_ohm metadata; NaN where neither."""
    return ra_ohm if ra_ohm is not None else number_or_nan(meta.get("ra_ohm"))


def speed_of_log(path, df, meta: dict, opts: Options, ra_ohm: float | None = None,
                 ke_vs_per_rad: float | None = None, bursts=None, model: ModelPrior | None = None,
                 rpm_range=None, ke_source: str = "user"):
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
    is no back-EMF prior: rpm_range (lo, hi) RPM is the prior, or none (speed_range.range_prior), Ke
    NaN. Where rpm_range is given, a confident count outside it is not confident (within_range). Free-running
    bursts have their PWM-synchronous average removed first (sync.prepare). ke_source: where a Ke given
    (ke_vs_per_rad) comes from, in words (speed_of_bench's Ke from other recordings of the motor). Under a Ke
    given or a model, the figure is checked against it (line.prior_checks_figure: `ke_or_figure` where the two
    disagree); speed_of_bench checks it over a motor's recordings together, which a lone steady run cannot."""
    got = _count_log(path, df, meta, opts, ra_ohm, ke_vs_per_rad, bursts, model, rpm_range, ke_source)
    return _prior_checked([got], opts, model, ke_vs_per_rad)[0]


def _prior_checked(got, opts: Options, model, ke_vs_per_rad) -> list:
    """_count_log's results for a motor's recordings as (estimate, Ke, where Ke came from), with the figure given
    checked against a Ke the user gave, or a model's, over them together (line.prior_checks_figure)."""
    out = [g[:3] for g in got]
    if not (model is not None or ke_vs_per_rad):
        return out
    have = [k for k, g in enumerate(got) if g[4] is not None]
    if have:
        checked = prior_checks_figure([got[k][0] for k in have], [got[k][4] for k in have], opts, got[have[0]][1],
                                      got[have[0]][2])
        for k, est in zip(have, checked):
            out[k] = (est, *out[k][1:])
    return out


def _count_log(path, df, meta: dict, opts: Options, ra_ohm, ke_vs_per_rad, bursts, model, rpm_range, ke_source):
    """speed_of_log's (estimate, Ke, where Ke came from) before the figure is checked against a Ke given; where Ke
    is calibrated from the ripple the windows that told it whose comb places the line at the figure given
    (calibrate.placed_only of ke_evidence), else None: speed_of_bench pools them over a motor's recordings; and
    where the user's Ke or a model's is the prior, its sd (m2_prior_sd_rpm), else None: _prior_checked checks the
    figure against that Ke over the motor's recordings together."""
    from ..logs import ripple as rf
    from ..logs.errors import InputError
    from . import speed_range

    placed = None
    bpath = rf.path_for(path)
    if bursts is None and not bpath.exists():
        raise InputError(f"{path}: no current bursts beside it ({bpath.name}); record them in the ripple "
                         "mode (hpddo twin --ripple-hz, docs/ripple.md)")
    raw = rf.read(bpath) if bursts is None else bursts
    b = sync.prepare(raw, str(bpath))
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
        ra = ra_of(meta, ra_ohm)
        if not math.isfinite(ra):  # no back-EMF prior: the user's speed range, or none
            ke, ke_from = math.nan, "no Ra: " + ("the speed range given is the prior" if rpm_range else "no prior")
        elif ke_vs_per_rad:
            ke, ke_from = float(ke_vs_per_rad), ke_source
        else:
            evidence = ke_evidence(b, duty, v, i, ra, opts)
            ke, n_ke, ke_rel = calibrated(evidence)
            placed = placed_only(evidence)
            # its doubt is said, not put into the prior's spread: Ke's relative error there (prior_rel_sd) scales
            # with each candidate's speed, and at 0.35 no line however fast would be far from the prior
            ke_from = f"ripple ({n_ke} windows" + (f", to +-{ke_rel:.0%}" if math.isfinite(ke_rel) else "") + ")"
        prior = m2_prior_rpm(v, i, ra, ke) if math.isfinite(ke) else None
    per_A = rpm_per_amp(ra, ke) if math.isfinite(ke) and math.isfinite(ra) else None
    prior_sd = m2_prior_sd_rpm(v, i, ra, ke, opts) if prior is not None else None
    turning_given = False  # the user's speed range as the prior, above 0: the shaft turns (estimate_window)
    if prior is None and rpm_range is not None:
        prior, prior_sd = speed_range.range_prior(rpm_range, len(rows))
        turning_given = float(rpm_range[0]) > 0
    est = estimate(b, duty, prior, opts, prior_sd, per_A, turning_given=turning_given)
    est = count_settled_tails(b, duty, est, opts, per_A)
    est = count_steady_spans(b, duty, est, opts, per_A)
    est = count_stalls(b, duty, est, opts, per_A if prior is not None else None)
    # the speed's scale is checked where the prior's Ke is the user's or a model's (where the counts agree with it:
    # prior_checks_figure), or the user gives a speed range narrow enough; a Ke calibrated from the ripple under the
    # figure given scales with it
    ke_given = model is not None or bool(ke_vs_per_rad)
    est = identity_of_recording(est, opts, scale_checked=ke_given or speed_range.range_checks_figure(rpm_range))
    est = speed_range.within_range(est, rpm_range)
    est = unseen_demoted(est, sync.pwm_unseen(raw), raw.pwm_hz)
    est.insert(1, "row", np.asarray(rows, np.int64))
    est["rpm_prior"] = np.nan if prior is None else prior
    return est, ke, ke_from, placed, prior_sd if ke_given and prior is not None else None


def speed_of_bench(logs, opts: Options, ra_ohm: float | None = None, ke_vs_per_rad: float | None = None,
                   model: ModelPrior | None = None, rpm_range=None) -> list:
    """The ripple speed of every window of several recordings of one motor (logs: (path, df, meta, bursts or
    None) each, as speed_of_log takes them), each counted by speed_of_log; then the figure given checked over
    the motor, not per recording. Where Ke is calibrated from the ripple (no Ke, no model given) a recording
    whose combs do not confirm the figure it is counted under (too few windows show one) cannot check it, and
    none of its windows is confident (`unchecked`, line.identity_of_recording). Where the motor's other
    recordings' combs confirm
    the figure (figure_shown), their windows whose comb places the line at it tell Ke under a checked figure
    (calibrate.ke_evidence, pooled): such a recording is counted again with that Ke as its back-EMF prior,
    which then checks its line as a user's Ke does. Returns speed_of_log's (estimate, Ke, where Ke came
    from) per log, in order."""
    from ..logs import ripple as rf

    # each log's bursts read once (a missing file is speed_of_log's error to name)
    logs = [(p, df, meta, b if b is not None or not rf.path_for(p).exists() else rf.read(rf.path_for(p)))
            for p, df, meta, b in logs]
    got = [_count_log(p, df, meta, opts, ra_ohm, ke_vs_per_rad, b, model, rpm_range, "user") for p, df, meta, b in logs]
    out = _prior_checked(got, opts, model, ke_vs_per_rad)
    if model is not None or ke_vs_per_rad:
        return out
    unchecked = [k for k, (est, _, _) in enumerate(out)
                 if (est["key"] == "unchecked").any() and math.isfinite(ra_of(logs[k][2], ra_ohm))]
    # the recordings whose Ke the ripple told (calibrate.ke_evidence's placed windows, kept by _count_log); an
    # unchecked one among them too: its windows whose comb places the line at the figure are evidence, too few alone
    told = [k for k in range(len(out)) if got[k][3] is not None and math.isfinite(out[k][1])]
    for k in unchecked:
        checking = [j for j in told if j != k]
        confirmed, at, shown = figure_shown([out[j][0] for j in checking], opts)
        if not confirmed:
            continue
        ke, n_ke, ke_rel = ke_of({key: np.concatenate([got[j][3][key] for j in checking])
                                  for key in got[checking[0]][3]})
        if not (n_ke and ke > 0):
            continue
        names = ", ".join(pathlib.Path(str(logs[j][0])).stem for j in checking)
        source = (f"ripple of the motor's other recordings ({n_ke} windows of {names} whose comb shows the "
                  f"{opts.ripples_per_rev} given, in {at} of their {shown} comb windows"
                  + (f"; to +-{ke_rel:.0%}" if math.isfinite(ke_rel) else "") + ")")
        p, df, meta, b = logs[k]
        # (the figure is the combs' to check here, not this Ke's: it was told under the figure they confirm)
        out[k] = _count_log(p, df, meta, opts, ra_ohm, ke, b, None, rpm_range, source)[:3]
    return out
