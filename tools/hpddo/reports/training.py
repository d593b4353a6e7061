"""The training report (hpddo train, hpddo demo): the RMSE table (as the paper's Table 6)
and, per recording, the estimates of M1, M2 and M3 each against the encoder in its own panel,
with the chronological split marked (as the paper's Figures 12-18), plus the M2 and M3 errors
over time; a long recording as binned means with bands (overlay_figure). One self-contained page, out/index.html (templates/training.html.j2)."""
from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from ..evaluation.metrics import read_estimates  # noqa: E402
from ..logs import benchlog  # noqa: E402
from . import png, render  # noqa: E402

MODELS = ("M1", "M2", "M3")
COLOURS = {"rpm_ref": "#222222", "rpm_m1": "#d62728", "rpm_m2": "#1f77b4", "rpm_m3": "#2ca02c"}
CAPTION = "RMSE on the held-out test parts (RPM)"


def rmse_rows(metrics: dict, models=MODELS) -> list[dict]:
    """The rows of the RMSE table: every condition, then the average; per model its value
    and whether it is the row's best."""
    rm = metrics["rmse_rpm"]
    conds = [c for c in rm[models[0]] if c != "average"] + ["average"]
    rows = []
    for c in conds:
        vals = [rm[m].get(c) for m in models]
        best = min((v for v in vals if v is not None), default=None)  # None: no encoder readings to score
        rows.append({"condition": c, "cells": [{"value": v, "best": v is not None and v == best} for v in vals]})
    return rows


#: A panel draws at most this many points a series: a longer recording is drawn as the mean of
#: each of BINS equal stretches of time, with the band its rows span (10th to 90th percentile),
#: so that 7 200 noisy M2 samples do not paint over M3 and the encoder.
MAX_POINTS = 1500
BINS = 400


def binned(t, x, bins: int = BINS):
    """(time, mean, 10th percentile, 90th percentile) of x over `bins` equal stretches of time t
    (increasing, as t_s is; the stretches without a finite value left out), one stretch at a time
    (no copy of the whole series); x itself (band: itself) where it has at most MAX_POINTS rows."""
    import numpy as np

    t, x = np.asarray(t, float), np.asarray(x, float)
    if len(t) <= MAX_POINTS:
        return t, x, x, x
    edges = np.linspace(t[0], t[-1], bins + 1)
    cut = np.searchsorted(t, edges[1:-1], side="right")
    rows = []
    for a, b in zip(np.r_[0, cut], np.r_[cut, len(t)]):
        xs = x[a:b]
        xs = xs[np.isfinite(xs)]
        if len(xs):
            rows.append((t[a:b].mean(), xs.mean(), *np.percentile(xs, [10, 90])))
    tb, mean, lo, hi = np.array(rows).T if rows else (np.zeros(0),) * 4
    return tb, mean, lo, hi


def binned_rms(t, e, bins: int = BINS):
    """(time, RMS of e) over `bins` equal stretches of time (e itself, as |e|, on a short recording)."""
    import numpy as np

    t, e = np.asarray(t, float), np.asarray(e, float)
    if len(t) <= MAX_POINTS:
        return t, np.abs(e)
    tb, m2, _, _ = binned(t, e * e, bins)
    return tb, np.sqrt(m2)


def _series(ax, t, y, colour: str, label: str, lw: float) -> None:
    """A series as its binned mean with its band (binned)."""
    tb, mean, lo, hi = binned(t, y)
    if len(tb) != len(t):
        ax.fill_between(tb, lo, hi, color=colour, alpha=0.18, lw=0)
    ax.plot(tb, mean, color=colour, lw=lw, label=label)


def overlay_figure(est: pd.DataFrame, title: str) -> str:
    """Four panels, each model against the encoder on its own so that none hides another: M1
    (it is off by a factor, at its own scale), M2, M3, and the errors of M2 and M3 (their RMS);
    a long recording drawn as binned means with the 10-90 % band of each bin (binned); the
    split as a dashed line."""
    import numpy as np

    fig, axes = plt.subplots(4, 1, figsize=(11, 8.4), sharex=True,
                             gridspec_kw={"height_ratios": [1.2, 2, 2, 1.4]})
    ax1, ax2, ax3, ax4 = axes
    t = est["t_s"].to_numpy(float)
    ref = est["rpm_ref"].to_numpy(float)
    long = len(t) > MAX_POINTS
    how = f" (means of {BINS} stretches of time, band: 10-90 % of their rows)" if long else ""
    for ax, col, label, lw in ((ax1, "rpm_m1", "M1 nameplate", 1.2), (ax2, "rpm_m2", "M2 identified physics", 2.2),
                               (ax3, "rpm_m3", "M3 hybrid", 2.2)):
        _series(ax, t, est[col].to_numpy(float), COLOURS[col], label, lw)
        _series(ax, t, ref, COLOURS["rpm_ref"], "encoder", 1.1)  # on top: the model's line shows around it
        ax.set_ylabel("RPM")
    ax1.set_title(title + how, fontsize=10)
    ax2.set_ylabel("output shaft\nspeed (RPM)")
    scored = np.isfinite(ref)
    for col, label, lw in (("rpm_m2", "M2", 1.8), ("rpm_m3", "M3", 1.4)):
        e = est[col].to_numpy(float) - ref
        rmse = float(np.sqrt(np.mean(e[scored] ** 2))) if scored.any() else float("nan")
        tb, r = binned_rms(t[scored], e[scored])
        ax4.plot(tb, r, color=COLOURS[col], lw=lw, label=f"{label} |error|{' RMS' if long else ''}, "
                                                          f"{rmse:.2f} RPM RMSE")
    ax4.set_ylabel("error (RPM)")
    ax4.set_ylim(bottom=0)
    ax4.set_xlabel("time (s)")
    test = est.index[est["part"] == "test"]
    split = len(test) > 0 and test[0] > 0  # no line where every row is scored (hpddo evaluate)
    for a in axes:
        if split:
            a.axvline(t[test[0]], color="k", ls="--", lw=1)
        a.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, frameon=False)  # beside the data
        a.grid(alpha=0.3)
    if split:
        ax1.text(t[test[0]], 1.0, " test part (last 20 %)", va="bottom", fontsize=9,
                 transform=ax1.get_xaxis_transform())
    return png(fig)


def page(metrics: dict, recordings: list[dict], title: str, notes: list[str], caption: str = CAPTION) -> str:
    """The page's HTML; recordings: [{"name", "figure" (a data URI)}]."""
    models = [m for m in (*MODELS, "lookup") if m in metrics["rmse_rpm"]]
    return render("training.html.j2", title=title, notes=list(notes),
                  table={"caption": caption, "models": models, "rows": rmse_rows(metrics, models)},
                  clamped=metrics.get("clamped_share", {}), fallback=metrics.get("fallback_share", {}),
                  gated=metrics.get("gated_share", {}),
                  glitches=metrics.get("glitches_removed", {}), warnings=metrics.get("warnings", []),
                  recordings=recordings)


def write(metrics: dict, estimates_dir: pathlib.Path, out: pathlib.Path, title: str, notes: list[str],
          caption: str = CAPTION) -> pathlib.Path:
    """Writes out/index.html (self-contained: figures are embedded); returns its path."""
    recordings = []
    for f in sorted(pathlib.Path(estimates_dir).glob("*.estimates.csv")):
        name = f.name.replace(".estimates.csv", "")
        recordings.append({"name": name, "figure": overlay_figure(read_estimates(f), name)})
    return benchlog.write_text_atomic(pathlib.Path(out) / "index.html", page(metrics, recordings, title, notes, caption))


def write_evaluation(ev, out: pathlib.Path, title: str, notes: list) -> pathlib.Path:
    """Writes an evaluation's (hpddo.evaluation.evaluate.Evaluation) metrics.json and
    report/index.html into out; the page."""
    (pathlib.Path(out) / "metrics.json").write_text(benchlog.json_text(ev.metrics, indent=2))
    return write(ev.metrics, ev.estimates, pathlib.Path(out) / "report", title, notes,
                 caption=ev.table.splitlines()[0])
