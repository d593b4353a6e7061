"""The diagnosis report (hpddo diagnose): one self-contained page, index.html
(templates/diagnosis.html.j2: the verdict, the RMSE table before and after, the ranked
effects with their plausibility, the overlays, where the error sits, and the whiteness
and correlation plots), and the JSON summary, diagnosis.json, written into a staging
folder that the caller renames into place."""
from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..logs import benchlog  # noqa: E402
from ..diagnosis import analysis, ranking  # noqa: E402
from . import png, render  # noqa: E402

RESIDUALS = (("residual_before", "model under test"), ("residual_after", "after adding the missing effects"))


def fig_overlays(res, plot):
    rows = plot["rows"]
    hyb = plot["hybrid"]
    fig, axes = plt.subplots(len(rows), 1, figsize=(12, 2.8 * len(rows)), squeeze=False)
    for ax, r, b, a, k in zip(axes[:, 0], rows, plot["est_before"], plot["est_after"], range(len(rows))):
        t = r.rec.df["t_s"].to_numpy(float)
        ax.plot(t, r.ref, color="black", lw=0.8, label="encoder")
        ax.plot(t, b, color="tab:red", lw=0.7, alpha=0.8, label="physics before")
        if res["missing_effects"]:
            ax.plot(t, a, color="tab:blue", lw=0.7, alpha=0.8, label="physics after")
        if hyb:
            ax.plot(t, hyb["after"][k], color="tab:green", lw=0.7, alpha=0.8, label="hybrid after")
        ax.axvline(t[r.rec.n_train], color="gray", ls="--", lw=1)
        ax.text(t[r.rec.n_train], ax.get_ylim()[1], " test →", va="top", fontsize=8, color="gray")
        ax.set_title(f"{r.rec.name} ({r.rec.source.name})", fontsize=10)
        ax.set_ylabel("RPM")
        ax.legend(fontsize=7, loc="lower left", ncol=4)
    axes[-1, 0].set_xlabel("t (s)")
    fig.tight_layout()
    return png(fig, crop=False)


def fig_where(res, plot):
    rows = plot["rows"]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    e_b = [e for e in plot["res_before"]]
    e_a = [e for e in plot["res_after"]]
    # by time: squared error per recording, test rows
    for r, eb, ea in zip(rows, e_b, e_a):
        m = r.test
        t = r.rec.df["t_s"].to_numpy(float)
        axes[0].plot(t[m], eb[m] ** 2, ".", ms=1.5, label=f"{r.rec.name} before")
    axes[0].set_yscale("symlog", linthresh=1.0)
    axes[0].set_xlabel("t (s), held-out rows")
    axes[0].set_ylabel("squared error (RPM²)")
    axes[0].set_title("by time", fontsize=10)
    axes[0].legend(fontsize=7)
    # operating point: speed against current, colour = squared error
    ii = np.concatenate([r.i[r.test | r.train] for r in rows])
    nn = np.concatenate([r.ref[r.test | r.train] for r in rows])
    ee = np.concatenate([e[r.test | r.train] ** 2 for r, e in zip(rows, e_b)])
    ok = np.isfinite(ee)
    sc = axes[1].scatter(ii[ok], nn[ok], c=np.log10(1 + ee[ok]), s=3, cmap="viridis")
    fig.colorbar(sc, ax=axes[1], label="log10(1 + e²)")
    axes[1].set_xlabel("current (A)")
    axes[1].set_ylabel("speed (RPM)")
    axes[1].set_title("by operating point (before)", fontsize=10)
    # by temperature
    tt = np.concatenate([r.temp[r.test | r.train] for r in rows])
    ea_all = np.concatenate([e[r.test | r.train] ** 2 for r, e in zip(rows, e_a)])
    for lab, e2 in (("before", ee), ("after", ea_all)):
        b = analysis.binned_mse(tt, e2)
        if b["mse"]:
            mid = 0.5 * (np.array(b["edges"][1:]) + np.array(b["edges"][:-1]))
            axes[2].plot(mid, b["mse"], "o-", label=lab)
    axes[2].set_xlabel("temperature (°C)")
    axes[2].set_ylabel("mean squared error (RPM²)")
    axes[2].set_title("by temperature (all rows)", fontsize=10)
    if axes[2].get_lines():
        axes[2].legend(fontsize=7)
    else:  # no temperature read (a dyno table)
        axes[2].text(0.5, 0.5, "no temperature read", ha="center", va="center", transform=axes[2].transAxes)
    fig.tight_layout()
    return png(fig, crop=False)


# the correlograms' lags as lines of this width (points), one collection an axis: a bar chart's patch a lag took
# 0.5 s a figure to lay out and draw on the 13.6k-row bench, a third of the report's figures
BAR_LW = 2.5


def fig_corr(an, title):
    cors = an["correlates"]
    w = an["whiteness"]
    n = 1 + len(cors)
    fig, axes = plt.subplots(1, n, figsize=(2.6 * n, 2.6), squeeze=False)
    ax = axes[0, 0]
    if w["acf"]:
        lags = np.arange(len(w["acf"]))
        ax.vlines(lags[1:], 0.0, w["acf"][1:], color="tab:blue", lw=BAR_LW)
        ax.axhspan(-w["band"], w["band"], color="gray", alpha=0.3)
    ax.set_title("residual ACF", fontsize=9)
    ax.set_xlabel("lag")
    for ax, c in zip(axes[0, 1:], cors):
        lags = np.arange(len(c["ccf"])) - (len(c["ccf"]) - 1) // 2
        ax.vlines(lags, 0.0, c["ccf"], color="tab:red" if c["significant"] else "tab:gray", lw=BAR_LW)
        ax.axhspan(-c["band"], c["band"], color="gray", alpha=0.3)
        ax.set_title(f"e vs {c['input']}", fontsize=9)
        ax.set_xlabel("lag")
        ax.set_ylim(-1, 1)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return png(fig, crop=False)


def rmse_rows(res) -> tuple[list[str], list[tuple[str, dict]]]:
    """The RMSE table: its conditions (the average last) and its rows (label, values)."""
    conds = [c for c in res["rmse_rpm"]["before"] if c != "average"] + ["average"]
    added = " + " + ", ".join(res["missing_effects"]) if res["missing_effects"] else " (nothing added)"
    rows = [("physics, before", res["rmse_rpm"]["before"]), ("physics, after" + added, res["rmse_rpm"]["after"])]
    if "rmse_rpm_hybrid" in res:
        rows += [("hybrid, before", res["rmse_rpm_hybrid"]["before"]),
                 ("hybrid, after", res["rmse_rpm_hybrid"]["after"])]
    return conds, rows


def page(res, figs) -> str:
    """The page's HTML; figs: data URIs by key (overlays, where, residual_before, residual_after)."""
    conds, rows = rmse_rows(res)
    return render("diagnosis.html.j2", res=res, conditions=conds, rmse_rows=rows, figures=figs,
                  residuals=RESIDUALS, few_blocks=ranking.FEW_BLOCKS)


def _figure(job) -> str:
    """One of the page's figures (a data URI), job = (key, res, plot)."""
    key, res, plot = job
    if key == "overlays":
        return fig_overlays(res, plot)
    if key == "where":
        return fig_where(res, plot)
    return fig_corr(res[key], dict(RESIDUALS)[key])


FIGURES = ("overlays", "where", *(key for key, _ in RESIDUALS))


def figures(res, plot) -> dict:
    """The page's figures by key, drawn on every core (interrupt.map_on_cores: matplotlib draws them in
    about 2.2 s one after the other on the 13.6k-row bench, half of the report's time; the same PNGs)."""
    from .. import interrupt

    return dict(zip(FIGURES, interrupt.map_on_cores(_figure, [(key, res, plot) for key in FIGURES])))


def summary(res) -> str:
    """diagnosis.json's text."""
    return benchlog.json_text(res, indent=1, default=_json_default)


def write(stage, res, plot):
    """Writes stage/index.html and stage/diagnosis.json."""
    stage = pathlib.Path(stage)
    benchlog.write_text_atomic(stage / "index.html", page(res, figures(res, plot)))
    benchlog.write_text_atomic(stage / "diagnosis.json", summary(res))


def _json_default(o):
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.bool_,)):
        return bool(o)
    raise TypeError(type(o))
