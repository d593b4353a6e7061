"""The report of hpddo compare: every table of the comparison, ours beside the paper's,
each with the command that reproduces it (templates/compare.html.j2)."""
from __future__ import annotations

import pathlib

from . import png, render

EFFECTS_ROW = "M2 + effects"  # compare's name of the physics model with the --effects terms


def shown_name(method: str, effects) -> str:
    """A method as the page shows it: the effects row names its effects."""
    return f"M2 + {', '.join(effects)}" if method == EFFECTS_ROW and effects else method


def paper_value(row: dict, cond: str, conds) -> float | None:
    """The paper's figure of a method (row: {condition: rmse}) under a table's column cond (conds: its columns):
    its average is over its own conditions, so it stands only under a table of the same ones (a table of two of
    them printed the paper's three-condition average under their column)."""
    if cond == "average" and {c for c in row if c != "average"} != {c for c in conds if c != "average"}:
        return None
    return row.get(cond)


def rmse_rows(rm: dict, paper: dict | None = None, effects=()) -> tuple[list, list]:
    """(columns, rows) of an RMSE table {method: {condition: rmse}}; a paper row under each
    method the paper reports."""
    cols = [c for c in next(iter(rm.values())) if c != "average"] + ["average"]
    rows = []
    for m, v in rm.items():
        rows.append({"name": shown_name(m, effects), "values": [v.get(c) for c in cols], "paper": False})
        if paper and m in paper:
            rows.append({"name": f"{m} (paper)", "values": [paper_value(paper[m], c, cols) for c in cols],
                         "paper": True})
    return cols, rows


def _splits(t7: dict) -> dict:
    """{split label: {method: average RMSE}} of Table 7, measured splits only."""
    out = {"chronological test parts": t7["chronological"]["rmse_rpm"]}
    if "validation" in t7:
        out["never-seen recordings"] = t7["validation"]["rmse_rpm"]
    out["leave one recording out"] = t7["leave_one_out"]["rmse_rpm"]
    return {k: {m: v.get("average") for m, v in rm.items()} for k, rm in out.items()}


def figure(t7: dict, effects) -> str:
    """Table 7's averages as bars, one group per method, a bar per split (log scale: M1 is
    tens of times the others)."""
    import matplotlib.pyplot as plt
    import numpy as np

    splits = _splits(t7)
    methods = list(next(iter(splits.values())))
    fig, ax = plt.subplots(figsize=(10, 3.8))
    width = 0.8 / len(splits)
    for k, (label, avg) in enumerate(splits.items()):
        vals = [avg.get(m) if avg.get(m) is not None else np.nan for m in methods]
        ax.bar(np.arange(len(methods)) + (k - (len(splits) - 1) / 2) * width, vals, width, label=label)
    ax.set_xticks(np.arange(len(methods)), [shown_name(m, effects) for m in methods], rotation=20, ha="right")
    ax.set_yscale("log")
    ax.set_ylabel("RMSE, average (RPM)")
    ax.grid(axis="y", which="both", alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    ax.set_title("Table 7 on these recordings (lower is better)")
    return png(fig)


def verdict(t7: dict, effects) -> list:
    """What Table 7 says, in sentences computed from its figures: the best method where no
    training row is scored, and whether the residual network beat its physics there."""
    splits = _splits(t7)
    unseen_key = "never-seen recordings" if "never-seen recordings" in splits else "leave one recording out"
    unseen, chrono = splits[unseen_key], splits["chronological test parts"]
    ranked = sorted((v, m) for m, v in unseen.items() if v is not None and m != "lookup")
    out = []
    if ranked:
        v, m = ranked[0]
        out.append(f"On the {unseen_key} (no training row scored), the most accurate method is "
                   f"{shown_name(m, effects)}, {v:.2f} RPM.")
    for net, phys in (("M3 gated", EFFECTS_ROW if EFFECTS_ROW in unseen else "M2"), ("M3", "M2")):
        if unseen.get(net) is not None and unseen.get(phys) is not None:
            d = unseen[net] - unseen[phys]
            out.append(f"There, {net} is {abs(d):.2f} RPM {'worse' if d > 0 else 'better'} than "
                       f"{shown_name(phys, effects)} ({unseen[net]:.2f} against {unseen[phys]:.2f}).")
            break
    if chrono.get("lookup") is not None and unseen.get("lookup") is not None and chrono.get("M3") is not None:
        out.append(f"The lookup baseline (memory alone) scores {chrono['lookup']:.2f} RPM on the chronological "
                   f"test parts and {unseen['lookup']:.2f} on the {unseen_key}: where a network is near the lookup "
                   "on the first and far from the physics on the second, it has memorised the recordings.")
    return out


def ripple_notes(part: dict) -> list:
    """The ripple rows' coverage under a Table 7 section (none without ripple rows)."""
    return [part["ripple_note"]] if part.get("ripple_note") else []


def write(tables: dict, out: pathlib.Path, command: str, seconds: float) -> pathlib.Path:
    """Writes out/index.html; returns it."""
    t7, t8, t9, t10, ood = (tables[k] for k in ("table7", "table8", "table9", "table10", "ood"))
    st = t7.get("settings", {})
    effects = st.get("effects", ())
    quick = (f"A quick look (--quick): {st.get('epochs')} epochs per network, two architectures, coarse "
             "tuning of the observers. Its networks are not trained as hpddo train trains M3 (2000 epochs), so "
             "their figures are not the comparison; run without --quick for it.") if st.get("quick") else None
    sections = []
    sections.append({"title": "Table 7, chronological test parts", "what": t7["chronological"]["what"],
                     "table": rmse_rows(t7["chronological"]["rmse_rpm"], t7["paper"], effects),
                     "notes": ripple_notes(t7["chronological"])})
    if "validation" in t7:
        sections.append({"title": "Table 7, never-seen recordings", "what": t7["validation"]["what"],
                         "table": rmse_rows(t7["validation"]["rmse_rpm"], effects=effects),
                         "notes": ripple_notes(t7["validation"])})
    sections.append({"title": "Table 7, leave one recording out", "what": t7["leave_one_out"]["what"],
                     "table": rmse_rows(t7["leave_one_out"]["rmse_rpm"], effects=effects),
                     "notes": ripple_notes(t7["leave_one_out"])})
    sections.append({"title": t8["title"], "what": t8["what"], "table": rmse_rows(t8["rmse_rpm"], t8["paper"])})
    rm9 = {f"{k}: {v['params']} params, {v['memory_kB']} kB": v["rmse_rpm"] for k, v in t9["rows"].items()}
    p9 = {f"{k}: {v['params']} params, {v['memory_kB']} kB": dict(zip(["sweep", "load", "long", "average"],
                                                                         t9["paper"][k][2:]))
          for k, v in t9["rows"].items() if k in t9["paper"]}
    sections.append({"title": t9["title"], "what": t9["what"], "table": rmse_rows(rm9, p9)})
    sections.append({"title": t10["title"], "what": t10["what"],
                     "table": rmse_rows({k: v["rmse_rpm"] for k, v in t10["rows"].items()}, t10["paper"])})
    for name, run in ood["runs"].items():
        notes = [f"clamp {run['clamp_rpm']} RPM, {run['train_rows']} training rows"]
        notes += [f"{cond}: clamped {100 * (s['clamped'] or 0):.1f} %, fallback {100 * (s['fallback'] or 0):.1f} %, "
                  f"gated {100 * (s['gated'] or 0):.1f} %" for cond, s in run["shares"].items()]
        notes += [f"eq. 26, {k}: {v['violations']} violations in {v['samples']} samples" for k, v in run["eq26"].items()]
        sections.append({"title": f"Section 4.10, trained on {name} only", "what": ood["what"],
                         "table": rmse_rows(run["rmse_rpm"]), "notes": notes})
    out.mkdir(parents=True, exist_ok=True)
    page = out / "index.html"
    checks = [f"{k}: " + (", ".join(f"{a} {b}" for a, b in v.items()) if isinstance(v, dict) else f"{v}")
              for k, v in t7.get("checks", {}).items()]
    paper = ood["paper"]
    p_rm = {k: v for k, v in paper.items() if isinstance(v, dict)}
    paper_notes = [f"clamp {paper['clamp_rpm']} RPM, {100 * paper['clamped_share_average']:.1f} % of the samples "
                   "clamped on average"]
    sections.append({"title": "Section 4.10 in the paper (its own recordings, trained on a dedicated recording)",
                     "what": "the paper's figures, quoted; the conditions it does not give are left empty",
                     "table": rmse_rows({k: {c: v.get(c) for c in ("sweep", "load", "long", "average")}
                                         for k, v in p_rm.items()}), "notes": paper_notes})
    for s in sections:
        s.setdefault("notes", [])
    page.write_text(render("compare.html.j2", sections=sections, command=command, seconds=f"{seconds:.0f}",
                           checks=checks, quick=quick, verdict=verdict(t7, effects),
                           figure=figure(t7, effects)), encoding="utf-8")
    return page
