"""The diagnosis report: one self-contained HTML page (figures embedded as PNG) and the
JSON summary, written into a staging folder that the caller renames into place."""
from __future__ import annotations

import base64
import html
import io
import json
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .. import effects as fx  # noqa: E402
from . import analysis  # noqa: E402


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def _fmt(x, nd=2):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return f"{x:.{nd}f}"


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
    return _png(fig)


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
    axes[2].legend(fontsize=7)
    fig.tight_layout()
    return _png(fig)


def fig_corr(an, title):
    cors = an["correlates"]
    w = an["whiteness"]
    n = 1 + len(cors)
    fig, axes = plt.subplots(1, n, figsize=(2.6 * n, 2.6), squeeze=False)
    ax = axes[0, 0]
    if w["acf"]:
        lags = np.arange(len(w["acf"]))
        ax.bar(lags[1:], w["acf"][1:], color="tab:blue")
        ax.axhspan(-w["band"], w["band"], color="gray", alpha=0.3)
    ax.set_title("residual ACF", fontsize=9)
    ax.set_xlabel("lag")
    for ax, c in zip(axes[0, 1:], cors):
        lags = np.arange(len(c["ccf"])) - (len(c["ccf"]) - 1) // 2
        ax.bar(lags, c["ccf"], color="tab:red" if c["significant"] else "tab:gray")
        ax.axhspan(-c["band"], c["band"], color="gray", alpha=0.3)
        ax.set_title(f"e vs {c['input']}", fontsize=9)
        ax.set_xlabel("lag")
        ax.set_ylim(-1, 1)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return _png(fig)


CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;max-width:1180px;margin:24px auto;
padding:0 16px;color:#222;line-height:1.45}
h1{font-size:1.6em;margin-bottom:0.2em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ddd}
table{border-collapse:collapse;margin:8px 0;font-size:0.92em}td,th{border:1px solid #ccc;padding:4px 8px;
text-align:right}th{background:#f3f3f3}td.l,th.l{text-align:left}
.verdict{font-size:1.1em;padding:12px 16px;border-radius:6px;background:#eef6ee;border:1px solid #9c9}
.warn{background:#fff6e5;border-color:#e0b050}.ok{color:#171}.bad{color:#b11}
img{max-width:100%}.small{font-size:0.85em;color:#555}
"""


def page(res, figs) -> str:
    esc = html.escape
    v_cls = "verdict" if not res["missing_effects"] else "verdict warn"
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>hpddo diagnosis</title>"
             f"<style>{CSS}</style></head><body>",
             "<h1>Diagnosis: where the physics model fails, and what is missing</h1>",
             f"<p class='small'>Recordings: {esc(', '.join(r['name'] + ' (' + str(r['rows']) + ' rows)' for r in res['recordings']))}. "
             f"Ra = {res['ra_ohm']:.4g} ohm ({esc(res['ra_source'])}). Model under test: M2"
             f"{' + ' + esc(', '.join(res['model_effects'])) if res['model_effects'] else ' (plain)'}. "
             f"Held-out rows: the last 20 % of each recording. Runtime {res['runtime_s']:.1f} s.</p>",
             f"<div class='{v_cls}'><b>Verdict.</b> {esc(res['verdict'])}</div>"]
    if res["not_identifiable"]:
        parts.append("<p class='small'>Not identifiable on these recordings (cannot be seen, whatever their size): " +
                     esc("; ".join(f"{u['effect']}: needs {u['needs']}" for u in res["not_identifiable"])) + ".</p>")
    # RMSE table
    conds = [c for c in res["rmse_rpm"]["before"] if c != "average"] + ["average"]
    hdr = "".join(f"<th>{esc(c)}</th>" for c in conds)
    parts.append("<h2>Error before and after adding the missing effects (RMSE on the test parts, RPM)</h2>")
    parts.append(f"<table><tr><th class='l'>model</th>{hdr}</tr>")
    added = " + " + ", ".join(res["missing_effects"]) if res["missing_effects"] else " (nothing added)"
    tab = [("physics, before", res["rmse_rpm"]["before"]), ("physics, after" + added, res["rmse_rpm"]["after"])]
    if "rmse_rpm_hybrid" in res:
        tab += [("hybrid, before", res["rmse_rpm_hybrid"]["before"]), ("hybrid, after", res["rmse_rpm_hybrid"]["after"])]
    for lab, d in tab:
        parts.append(f"<tr><td class='l'>{esc(lab)}</td>" + "".join(f"<td>{_fmt(d.get(c))}</td>" for c in conds) + "</tr>")
    parts.append("</table>")
    parts.append(f"<p class='small'>Noise level of the residual (white part, from row-to-row differences): "
                 f"{res['noise_rpm']:.2f} RPM.")
    if "rmse_rpm_hybrid" in res:
        parts.append(f" Hybrid: (16, 8) network retrained on top of each physics model for "
                     f"{res['rmse_rpm_hybrid']['iterations']} iterations (gen_weights trains 2000).")
    parts.append("</p>")
    # ranking
    parts.append("<h2>Candidate effects, ranked</h2>")
    parts.append("<table><tr><th class='l'>effect</th><th>named</th><th>score</th><th>z</th><th>inclusion</th>"
                 "<th class='l'>fitted parameter</th><th class='l'>plausibility</th><th class='l'>meaning</th></tr>")
    for e in res["ranking"]:
        named = "<b class='bad'>missing</b>" if e["named"] else ("–" if e["identifiable"] else "unseen")
        incl = "–" if e.get("inclusion") is None else f"{100 * e['inclusion']:.0f} %"
        par = esc(e.get("shown", "")) if e["params"] else "–"
        pl = e.get("plausibility", "")
        cls = "ok" if e.get("plausible") else ("bad" if e["params"] else "")
        parts.append(f"<tr><td class='l'>{esc(e['effect'])}</td><td>{named}</td><td>{_fmt(e['score'], 3)}</td>"
                     f"<td>{_fmt(e.get('z'), 1)}</td><td>{incl}</td><td class='l'>{par}</td>"
                     f"<td class='l {cls}'>{esc(pl)}</td><td class='l small'>{esc(e['meaning'])}</td></tr>")
    parts.append("</table><p class='small'>score: share of the held-out mean squared error of the model under test "
                 "that the effect removes (at its step of the forward selection; for effects not named, added to "
                 "the final model). z: that gain in standard errors of what noise would give. inclusion: share of "
                 "block-bootstrap resamples of the training rows in which the effect is named.</p>")
    if res["confounded"]:
        parts.append("<h2>Effects that these recordings cannot tell apart</h2><ul>")
        for s in res["separating_recordings"]:
            parts.append(f"<li><b>{esc(' / '.join(s['effects']))}</b> (regressors correlated r = {s['corr']:+.2f} "
                         f"once Ke is fitted): record {esc(s['recording'])}.</li>")
        parts.append("</ul>")
    parts.append("<h2>Estimate against encoder</h2><p class='small'>Dashed line: the chronological 80/20 split; "
                 "only the rows after it are scored.</p>")
    parts.append(f"<img alt='overlays' src='{figs['overlays']}'>")
    parts.append("<h2>Where the squared error sits (model under test)</h2>")
    parts.append(f"<img alt='where' src='{figs['where']}'>")
    parts.append("<h2>Is the residual noise?</h2>")
    for key, lab in (("residual_before", "model under test"), ("residual_after", "after adding the missing effects")):
        an = res[key]
        w = an["whiteness"]
        sig = [c for c in an["correlates"] if c["significant"]]
        parts.append(f"<p><b>{esc(lab)}</b>: held-out MSE {an['mse']:.2f} RPM², noise {an['noise_var']:.2f} RPM²; "
                     f"Ljung-Box Q = {_fmt(w['q'], 1)} over 20 lags, p = {_fmt(w['p'], 4)}; "
                     f"{_fmt(100 * (w['outside'] or 0), 0)} % of lags outside the 95 % band: "
                     f"{'white' if w['white'] else 'not white'}. Correlates outside their band: "
                     f"{esc(', '.join(c['input'] + ' (' + format(c['peak'], '+.2f') + ')' for c in sig) or 'none')}.</p>")
        parts.append(f"<img alt='correlation {esc(lab)}' src='{figs[key]}'>")
    parts.append("<p class='small'>Bands: ±1.96/√N for the autocorrelation; Bartlett's ±1.96 √(Σ r_ee r_uu / N) for "
                 "the cross-correlations, so that a slowly varying input is not mistaken for a correlate.</p>")
    parts.append("</body></html>")
    return "\n".join(parts)


def write(stage, res, plot):
    figs = {"overlays": fig_overlays(res, plot), "where": fig_where(res, plot),
            "residual_before": fig_corr(res["residual_before"], "model under test"),
            "residual_after": fig_corr(res["residual_after"], "after adding the missing effects")}
    (stage / "index.html").write_text(page(res, figs), encoding="utf-8")
    (stage / "diagnosis.json").write_text(json.dumps(res, indent=1, default=_json_default) + "\n")


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
