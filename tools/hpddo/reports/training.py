"""The training report (hpddo train, hpddo demo): the RMSE table (as the paper's Table 6)
and, per recording, the estimates of M1, M2 and M3 against the encoder with the
chronological split marked (as the paper's Figures 12-18), plus the M2 and M3 errors over
time. One self-contained page, out/index.html (templates/training.html.j2)."""
from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

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


def overlay_figure(est: pd.DataFrame, title: str) -> str:
    """Three panels: M1 against the encoder at full scale (it is off by a factor), M2 and
    M3 against the encoder, and the errors of M2 and M3; the split as a dashed line."""
    fig, (ax1, ax, ax2) = plt.subplots(3, 1, figsize=(11, 7.2), sharex=True,
                                       gridspec_kw={"height_ratios": [1.4, 3, 1.4]})
    t = est["t_s"]
    ax1.plot(t, est["rpm_ref"], color=COLOURS["rpm_ref"], lw=1.4, label="encoder")
    ax1.plot(t, est["rpm_m1"], color=COLOURS["rpm_m1"], lw=0.9, label="M1 nameplate")
    ax1.set_ylabel("RPM")
    ax1.set_title(title)
    ax.plot(t, est["rpm_ref"], color=COLOURS["rpm_ref"], lw=1.6, label="encoder")
    # M3 under M2: where the gate or the fallback leaves M3 equal to M2, M2 shows
    ax.plot(t, est["rpm_m3"], color=COLOURS["rpm_m3"], lw=1.3, label="M3 hybrid")
    ax.plot(t, est["rpm_m2"], color=COLOURS["rpm_m2"], lw=0.8, label="M2 identified physics")
    ax.set_ylabel("output shaft speed (RPM)")
    ax2.plot(t, est["rpm_m3"] - est["rpm_ref"], color=COLOURS["rpm_m3"], lw=1.1, label="M3 error")
    ax2.plot(t, est["rpm_m2"] - est["rpm_ref"], color=COLOURS["rpm_m2"], lw=0.7, label="M2 error")
    ax2.set_ylabel("error (RPM)")
    ax2.set_xlabel("time (s)")
    test = est.index[est["part"] == "test"]
    split = len(test) > 0 and test[0] > 0  # no line where every row is scored (hpddo evaluate)
    for a in (ax1, ax, ax2):
        if split:
            a.axvline(t.iloc[test[0]], color="k", ls="--", lw=1)
        a.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, frameon=False)  # beside the data
        a.grid(alpha=0.3)
    if split:
        ax1.text(t.iloc[test[0]], 1.0, " test part (last 20 %)", va="bottom", fontsize=9,
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
        recordings.append({"name": name, "figure": overlay_figure(pd.read_csv(f), name)})
    return benchlog.write_text_atomic(pathlib.Path(out) / "index.html", page(metrics, recordings, title, notes, caption))


def write_evaluation(ev, out: pathlib.Path, title: str, notes: list) -> pathlib.Path:
    """Writes an evaluation's (hpddo.evaluation.evaluate.Evaluation) metrics.json and
    report/index.html into out; the page."""
    import json
    (pathlib.Path(out) / "metrics.json").write_text(json.dumps(ev.metrics, indent=2) + "\n")
    return write(ev.metrics, ev.estimates, pathlib.Path(out) / "report", title, notes,
                 caption=ev.table.splitlines()[0])
