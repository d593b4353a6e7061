"""HTML report of a pipeline run: the RMSE table (as the paper's Table 6) and, per
recording, the estimates of M1, M2 and M3 against the encoder with the chronological
split marked (as the paper's Figures 12-18), plus the M3 error and status over time."""
from __future__ import annotations

import base64
import html
import io
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from . import benchlog  # noqa: E402

MODELS = ("M1", "M2", "M3")
COLOURS = {"rpm_ref": "#222222", "rpm_m1": "#d62728", "rpm_m2": "#1f77b4", "rpm_m3": "#2ca02c"}

CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; line-height: 1.45; }
h1 { font-size: 1.6em; } h2 { margin-top: 1.6em; border-bottom: 1px solid #ddd; }
table { border-collapse: collapse; margin: 1em 0; } th, td { padding: .3em .8em; text-align: right; }
th { background: #f2f2f2; } td:first-child, th:first-child { text-align: left; }
tr:nth-child(even) td { background: #fafafa; } .best { font-weight: bold; color: #1a7f37; }
img { max-width: 100%; } .note { color: #555; font-size: .92em; } code { background: #f4f4f4; padding: 0 .2em; }
"""


def png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def rmse_table(metrics: dict, models=MODELS, label="RMSE on the held-out test parts (RPM)") -> str:
    rm = metrics["rmse_rpm"]
    conds = [c for c in rm[models[0]] if c != "average"] + ["average"]
    rows = []
    for c in conds:
        vals = [rm[m].get(c) for m in models]
        best = min(v for v in vals if v is not None)
        cells = "".join(f'<td class="{"best" if v == best else ""}">{v:.2f}</td>' for v in vals)
        rows.append(f"<tr><td>{html.escape(c)}</td>{cells}</tr>")
    head = "".join(f"<th>{m}</th>" for m in models)
    return f"<table><caption>{label}</caption><tr><th>condition</th>{head}</tr>{''.join(rows)}</table>"


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
    ax.plot(t, est["rpm_m2"], color=COLOURS["rpm_m2"], lw=0.9, label="M2 identified physics")
    ax.plot(t, est["rpm_m3"], color=COLOURS["rpm_m3"], lw=0.9, label="M3 hybrid")
    ax.set_ylabel("output shaft speed (RPM)")
    ax2.plot(t, est["rpm_m2"] - est["rpm_ref"], color=COLOURS["rpm_m2"], lw=0.8, label="M2 error")
    ax2.plot(t, est["rpm_m3"] - est["rpm_ref"], color=COLOURS["rpm_m3"], lw=0.8, label="M3 error")
    ax2.set_ylabel("error (RPM)")
    ax2.set_xlabel("time (s)")
    test = est.index[est["part"] == "test"]
    for a in (ax1, ax, ax2):
        if len(test):
            a.axvline(t.iloc[test[0]], color="k", ls="--", lw=1)
        a.legend(loc="upper left", ncol=3, fontsize=8)
        a.grid(alpha=0.3)
    if len(test):
        ax1.text(t.iloc[test[0]], 1.0, " test part (last 20 %)", va="bottom", fontsize=9,
                 transform=ax1.get_xaxis_transform())
    return png(fig)


def write(metrics: dict, estimates_dir: pathlib.Path, out: pathlib.Path, title: str, notes: list[str]) -> pathlib.Path:
    """Writes out/index.html (self-contained: figures are embedded)."""
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>",
             f"<style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>"]
    parts += [f"<p class='note'>{html.escape(n)}</p>" for n in notes]
    parts.append(rmse_table(metrics))
    shares = metrics.get("clamped_share", {})
    fb = metrics.get("fallback_share", {})
    parts.append("<p class='note'>Residual clamp active on " + ", ".join(
        f"{c} {100 * v:.1f} %" for c, v in shares.items()) + "; physics fallback on " + ", ".join(
        f"{c} {100 * v:.1f} %" for c, v in fb.items()) + " of the test samples.</p>")
    removed = metrics.get("glitches_removed", {})
    if removed:
        parts.append("<p class='note'>RMSE over every test row with an encoder reading; rows removed by the "
                     "glitch filter before the split: " + ", ".join(
                         f"{html.escape(c)} {len(g['removed'])} of {g['rows_in_file']}" for c, g in removed.items())
                     + ".</p>")
    for w in metrics.get("warnings", []):
        parts.append(f"<p class='note'><strong>Warning:</strong> {html.escape(w)}</p>")
    for f in sorted(estimates_dir.glob("*.estimates.csv")):
        est = pd.read_csv(f)
        name = f.name.replace(".estimates.csv", "")
        parts.append(f"<h2>{html.escape(name)}</h2>")
        parts.append(f"<img alt='estimates of {html.escape(name)}' src='{overlay_figure(est, name)}'>")
    parts.append("</body></html>\n")
    return benchlog.write_text_atomic(out / "index.html", "".join(parts))
