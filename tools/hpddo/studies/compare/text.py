"""The comparison as text: the summary the command prints, and the markdown of docs/compare.md from a run's JSON files (python -m hpddo.studies.compare DIR)."""
from __future__ import annotations

import json
import sys
import pathlib
import shlex

from ...evaluation import metrics as metrics_mod
from ...logs.errors import InputError
from ...reports.compare import paper_value


def _cell(x) -> str:
    return metrics_mod.table_cell(x)


def rmse_text(title: str, rm: dict, paper: dict | None = None) -> str:
    conds = [c for c in next(iter(rm.values())) if c != "average"] + ["average"]
    lines = [title, f"{'method':<32s}" + "".join(f"{c:>10s}" for c in conds)]
    for m, v in rm.items():
        lines.append(f"{m:<32s}" + "".join(_cell(v.get(c)) for c in conds))
        if paper and m in paper:
            lines.append(f"{'  paper':<32s}" + "".join(_cell(paper_value(paper[m], c, conds)) for c in conds))
    return "\n".join(lines) + "\n"


def _note(part: dict) -> str:
    return f"  {part['ripple_note']}\n" if part.get("ripple_note") else ""


def text_summary(t: dict) -> str:
    t7 = t["table7"]
    st = t7.get("settings", {})
    head = []
    if st.get("quick"):
        head.append(f"A quick look (--quick: {st.get('epochs')} epochs per network, two architectures, coarse "
                    "tuning): not the comparison; run without --quick for it.\n")
    if st.get("effects"):
        head.append(f"M2 + effects: M2 with {', '.join(st['effects'])}.\n")
    head.append("Rows 'paper': the paper's figures on its own recordings, quoted; all others measured on yours.\n")
    parts = head + [rmse_text("Table 7, chronological test parts (RPM)", t7["chronological"]["rmse_rpm"], t7["paper"])
                    + _note(t7["chronological"])]
    if "validation" in t7:
        parts.append(rmse_text("Table 7, never-seen recordings (--validation), every row", t7["validation"]["rmse_rpm"])
                     + _note(t7["validation"]))
    parts.append(rmse_text("Table 7, leave one recording out, every row", t7["leave_one_out"]["rmse_rpm"])
                 + _note(t7["leave_one_out"]))
    parts.append(rmse_text("Table 8, M3", t["table8"]["rmse_rpm"], t["table8"]["paper"]))
    parts.append(rmse_text("Table 9, M3 per architecture", {f"{k} {v['params']} p": v["rmse_rpm"]
                                                            for k, v in t["table9"]["rows"].items()}))
    parts.append(rmse_text("Table 10, M3 per feature set", {k: v["rmse_rpm"] for k, v in t["table10"]["rows"].items()},
                           t["table10"]["paper"]))
    for name, run_ in t["ood"]["runs"].items():
        parts.append(rmse_text(f"Section 4.10, trained on {name} only (clamp {run_['clamp_rpm']} RPM)",
                               run_["rmse_rpm"]))
        parts.append("  eq. 26 violations: " + ", ".join(f"{k} {v['violations']}/{v['samples']}"
                                                        for k, v in run_["eq26"].items()) + "\n")
    return "\n".join(parts)


def command_line(argv) -> str:
    return "hpddo compare " + " ".join(shlex.quote(str(a)) for a in argv)


def _md_rmse(rm: dict, paper: dict | None = None, conds=None) -> list:
    conds = conds or [c for c in next(iter(rm.values())) if c != "average"] + ["average"]
    f = lambda v: "–" if v is None else f"{v:.2f}"
    lines = ["| method | " + " | ".join(conds) + " |", "|---" * (len(conds) + 1) + "|"]
    for m, v in rm.items():
        lines.append(f"| {m} | " + " | ".join(f(v.get(c)) for c in conds) + " |")
        if paper and m in paper:
            shown = [paper_value(paper[m], c, conds) for c in conds]
            lines.append(f"| *{m}, paper* | " + " | ".join(f"*{f(x)}*" if x is not None else "–" for x in shown) + " |")
    return lines


def markdown(folder: pathlib.Path) -> str:
    """The tables of docs/compare.md from table7.json ... ood.json in folder (a run's
    output, or docs/figures/compare_*.json with prefix)."""
    def load(name):
        for cand in (folder / f"{name}.json", folder / f"compare_{name}.json"):
            if cand.is_file():
                return json.loads(cand.read_text())
        raise InputError(f"{folder}: no {name}.json (an output of hpddo compare)")
    t7, t8, t9, t10, ood = (load(n) for n in ("table7", "table8", "table9", "table10", "ood"))
    out = [f"Command: `{t7['command']}`", "", "**Table 7, chronological test parts** (RMSE, RPM; paper in italics)", ""]
    out += _md_rmse(t7["chronological"]["rmse_rpm"], t7["paper"])
    if "validation" in t7:
        out += ["", "**Table 7, never-seen recordings** (every row of `--validation`)", ""]
        out += _md_rmse(t7["validation"]["rmse_rpm"])
    out += ["", "**Table 7, leave one recording out** (every row of the recording left out)", ""]
    out += _md_rmse(t7["leave_one_out"]["rmse_rpm"])
    out += ["", "**Table 8**, M3 under both protocols", ""] + _md_rmse(t8["rmse_rpm"], t8["paper"])
    out += ["", "**Table 9**, architecture ablation (M3, chronological test parts; paper in italics)", "",
            "| hidden | params | bytes | sweep | load | long | average | paper: params, kB, sweep, load, long, avg |",
            "|---|---|---|---|---|---|---|---|"]
    for k, v in t9["rows"].items():
        r = v["rmse_rpm"]
        p = t9["paper"].get(k)
        out.append(f"| {k} | {v['params']} | {v['bytes']} | " + " | ".join(f"{r[c]:.2f}" for c in CONDITIONS_DOC)
                   + " | " + (", ".join(f"{x:g}" for x in p) if p else "–") + " |")
    out += ["", "**Table 10**, feature ablation", ""]
    out += _md_rmse({k: v["rmse_rpm"] for k, v in t10["rows"].items()}, t10["paper"])
    for name, run_ in ood["runs"].items():
        out += ["", f"**Section 4.10, trained on {name} only** ({run_['train_rows']} training rows, clamp "
                    f"{run_['clamp_rpm']:.2f} RPM)", ""]
        out += _md_rmse(run_["rmse_rpm"])
        out += ["", "| tested on | clamped | fallback | gated |", "|---|---|---|---|"]
        out += [f"| {c} | {100 * s['clamped']:.1f} % | {100 * s['fallback']:.1f} % | {100 * s['gated']:.1f} % |"
                for c, s in run_["shares"].items()]
        out += ["", "eq. 26 on every labelled sample: " + "; ".join(
            f"{k}: {v['violations']} violations in {v['samples']}" for k, v in run_["eq26"].items())]
    return "\n".join(out) + "\n"


CONDITIONS_DOC = ("sweep", "load", "long", "average")


def main(argv=None) -> int:
    import argparse
    ap = argparse.ArgumentParser(prog="python -m hpddo.studies.compare",
                                 description="print the markdown tables of docs/compare.md from a run's JSON files")
    ap.add_argument("folder", type=pathlib.Path, help="an output of hpddo compare, or docs/figures")
    args = ap.parse_args(argv)
    print(markdown(args.folder), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
