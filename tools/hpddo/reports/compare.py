"""The report of hpddo compare: every table of the comparison, ours beside the paper's,
each with the command that reproduces it (templates/compare.html.j2)."""
from __future__ import annotations

import pathlib

from . import render


def rmse_rows(rm: dict, paper: dict | None = None) -> tuple[list, list]:
    """(columns, rows) of an RMSE table {method: {condition: rmse}}; a paper row under each
    method the paper reports."""
    cols = [c for c in next(iter(rm.values())) if c != "average"] + ["average"]
    rows = []
    for m, v in rm.items():
        rows.append({"name": m, "values": [v.get(c) for c in cols], "paper": False})
        if paper and m in paper:
            rows.append({"name": f"{m} (paper)", "values": [paper[m].get(c) for c in cols], "paper": True})
    return cols, rows


def write(tables: dict, out: pathlib.Path, command: str, seconds: float) -> pathlib.Path:
    """Writes out/index.html; returns it."""
    t7, t8, t9, t10, ood = (tables[k] for k in ("table7", "table8", "table9", "table10", "ood"))
    sections = []
    sections.append({"title": "Table 7, chronological test parts", "what": t7["chronological"]["what"],
                     "table": rmse_rows(t7["chronological"]["rmse_rpm"], t7["paper"])})
    if "validation" in t7:
        sections.append({"title": "Table 7, never-seen recordings", "what": t7["validation"]["what"],
                         "table": rmse_rows(t7["validation"]["rmse_rpm"])})
    sections.append({"title": "Table 7, leave one recording out", "what": t7["leave_one_out"]["what"],
                     "table": rmse_rows(t7["leave_one_out"]["rmse_rpm"])})
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
                           checks=checks), encoding="utf-8")
    return page
