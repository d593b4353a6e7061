"""Scores of the observer's estimates against the encoder: the RMSE table of M1, M2 and M3.

The native replay (host/replay.cpp) writes every row's estimates; this module turns
them into the figures every report shows, on the rows it is told to score:

* RMSE per condition (recording name), pooled over its scored rows that carry an
  encoder reading, and "average", the mean over the conditions that have such rows (a
  recording without an encoder speed has no RMSE, null, and no part in the average);
* the share of scored rows whose residual was clamped, that fell back to physics
  (outside the per-feature box), whose correction the novelty gate reduced ("gated"),
  or whose reading was invalid, per condition and over all ("all");
* the number of scored rows.

Figures are kept to 6 significant digits (what the reports print and what is compared
between machines; the last bits of a float32 sum are not).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd

#: Estimate columns scored, by model name: the observer's three, and the lookup baseline
#: (hpddo.evaluation.baseline) where the caller added it to every frame.
MODELS = {"M1": "rpm_m1", "M2": "rpm_m2", "M3": "rpm_m3", "lookup": "rpm_lookup"}
STATUS_SHARES = {"clamped_share": "clamped", "fallback_share": "fallback", "gated_share": "gated",
                 "invalid_share": "invalid"}


def figure(x: float) -> float | int | None:
    """x to 6 significant digits, as JSON reads the number printed so (an integer when it
    is one: 0, not 0.0); None (JSON null) when not finite."""
    return json.loads(f"{x:.6g}") if math.isfinite(x) else None


def rmse(err: np.ndarray) -> float:
    """Root mean square of the finite errors; NaN when there are none."""
    e = np.asarray(err, float)
    e = e[np.isfinite(e)]
    return float(np.sqrt(np.sum(e * e) / len(e))) if len(e) else float("nan")


def score(scored: list, source: str, checksum: int | None = None) -> dict:
    """scored: (condition, rpm_ref per row, estimates DataFrame, bool mask of the rows to
    score) per recording; recordings sharing a condition are pooled. Returns the metrics
    dict (rmse_rpm, the status shares, test_rows, source, model_checksum)."""
    models = {m: col for m, col in MODELS.items() if all(col in est for _, _, est, _ in scored)}
    order: list[str] = []
    err: dict[str, dict[str, list]] = {}
    status: dict[str, list] = {}
    n_labelled: dict[str, int] = {}
    for cond, ref, est, mask in scored:
        if cond not in err:
            order.append(cond)
            err[cond] = {m: [] for m in models}
            status[cond] = []
            n_labelled[cond] = 0
        mask = np.asarray(mask, bool)
        ref = np.asarray(ref, float)[mask]
        labelled = np.isfinite(ref)
        n_labelled[cond] += int(labelled.sum())
        for m, col in models.items():
            err[cond][m].append((est[col].to_numpy(float)[mask] - ref)[labelled])
        status[cond].append(est["status"].to_numpy(object)[mask])  # (references to a few words)
    out: dict = {"rmse_rpm": {}}
    scored_conds = [c for c in order if n_labelled[c]]  # (the same for every model: the encoder's rows)
    for m in models:
        per = {c: rmse(np.concatenate(err[c][m])) for c in order}
        avg = sum(per[c] / len(scored_conds) for c in scored_conds) if scored_conds else float("nan")
        out["rmse_rpm"][m] = {**{c: figure(v) for c, v in per.items()}, "average": figure(avg)}
    st = {c: np.concatenate(status[c]) for c in order}
    total = sum(len(s) for s in st.values())
    for key, name in STATUS_SHARES.items():
        out[key] = {c: figure(float(np.mean(st[c] == name)) if len(st[c]) else float("nan")) for c in order}
        out[key]["all"] = figure(sum(int(np.sum(s == name)) for s in st.values()) / total if total else float("nan"))
    out["test_rows"] = {**{c: len(st[c]) for c in order}, "all": total}
    out["source"] = source
    if checksum is not None:
        out["model_checksum"] = f"0x{checksum:08x}"
    return out


def table_cell(x: float | None, width: int = 10) -> str:
    """One RMSE of a text table, `width` wide; "-" where there is none (None or not finite: no encoder
    speed to score against)."""
    return f"{x:{width}.2f}" if x is not None and math.isfinite(x) else f"{'-':>{width}s}"


def table(metrics: dict, title: str = "RMSE on the test parts (RPM)") -> str:
    """The RMSE table as text: one line per condition, then the average."""
    rm = metrics["rmse_rpm"]
    models = [m for m in MODELS if m in rm]
    conds = [c for c in rm["M1"] if c != "average"]
    num = table_cell

    lines = [title, f"{'condition':<10s} " + " ".join(f"{m:>10s}" for m in models)
             + f" {'rows':>8s} {'clamped':>8s} {'fallback':>9s} {'gated':>8s}"]
    for c in conds:
        lines.append(f"{c:<10s} " + " ".join(num(rm[m][c]) for m in models)
                     + f" {metrics['test_rows'][c]:8d} {100 * (metrics['clamped_share'][c] or 0):7.1f}% "
                     f"{100 * (metrics['fallback_share'][c] or 0):8.1f}% "
                     f"{100 * (metrics.get('gated_share', {}).get(c) or 0):7.1f}%")
    lines.append(f"{'average':<10s} " + " ".join(num(rm[m]["average"]) for m in models))
    return "\n".join(lines) + "\n"


#: read_estimates parses this many rows at a time (its memory: the values, not the parser's
#: buffers over the whole file).
ESTIMATES_CHUNK_ROWS = 250_000
_TEXT_COLUMNS = ("status", "part")  # a handful of words each, over millions of rows: categories


def read_estimates(path) -> pd.DataFrame:
    """One estimates file of the replay (host/replay.cpp, --out-dir); status and part as
    categories (one copy of each word, not one per row)."""
    frames = []
    for f in pd.read_csv(path, dtype={c: str for c in _TEXT_COLUMNS}, chunksize=ESTIMATES_CHUNK_ROWS):
        frames.append(f.astype({c: "category" for c in _TEXT_COLUMNS if c in f}))
    if len(frames) == 1:
        return frames[0]
    columns = list(frames[0].columns)
    text = {c: pd.api.types.union_categoricals([f[c] for f in frames], ignore_order=True)
            for c in _TEXT_COLUMNS if c in frames[0]}
    out = pd.concat([f.drop(columns=list(text)) for f in frames], ignore_index=True)
    del frames
    for c, v in text.items():
        out[c] = pd.Categorical(v)
    return out[columns]
