"""Print the twin's M1/M2 tables (the numbers quoted in docs/twin.md).

    .venv/bin/python -m hpddo.twin.report            # with tools/ on PYTHONPATH
    .venv/bin/python -m hpddo.twin.report --dir data/default

Without --dir it simulates in memory: the default preset, the ideal preset, and each
effect alone on the ideal bench (seed 1, 2 Hz), and prints markdown tables of the
M2 RMSE (paper's eq. 20 Ke on the first 80 %, RMSE on the last 20 %, glitch rows
left out), its bias, M1 RMSE, and the identified Ke.
"""
from __future__ import annotations

import argparse
import json
import pathlib

import pandas as pd

from ..logs import benchlog
from . import check, generate, params

CONDS = ("sweep", "load", "long")


def _row(logs, exclude):
    out = {}
    for c in CONDS:
        out[c] = check.m_errors(logs[c], exclude=exclude[c])
    all_df = pd.concat([logs[c].drop(index=list(exclude[c])) for c in CONDS])
    ke_all = check.identify_ke(all_df["v_V"].to_numpy(), all_df["i_A"].to_numpy(),
                               all_df["rpm_ref"].to_numpy())
    return out, ke_all


def _fmt(label, out, ke_all):
    m2 = " | ".join(f"{out[c]['rmse_m2']:.2f} ({out[c]['bias_m2']:+.2f})" for c in CONDS)
    m1 = " | ".join(f"{out[c]['rmse_m1']:.1f}" for c in CONDS)
    return f"| {label} | {m2} | {m1} | {ke_all:.3f} |"


HEADER = ("| bench | M2 sweep (bias) | M2 load (bias) | M2 long (bias) | M1 sweep | M1 load | M1 long "
          "| Ke eq.20, all data |\n|---|---|---|---|---|---|---|---|")


def simulate_table(seed=1):
    lines = [HEADER]
    benches = [("default preset", params.preset("default")), ("ideal (all effects off)", params.preset("ideal"))]
    for name in params.EFFECT_NAMES:
        e = params.EFFECTS[name]
        benches.append((f"{name} = {e.default:g} {e.unit} alone",
                        params.with_effects(params.preset("ideal"), **{name: e.default})))
    for label, b in benches:
        logs, excl = {}, {}
        for c in CONDS:
            g = generate.generate(b, c, 2.0, seed)
            logs[c] = g["log"]
            excl[c] = [x["row"] for x in g["info"]["glitches"]]
        out, ke_all = _row(logs, excl)
        lines.append(_fmt(label, out, ke_all))
    return "\n".join(lines)


def dir_table(d):
    d = pathlib.Path(d)
    logs, excl, excl_none = {}, {}, {}
    for c in CONDS:
        logs[c] = benchlog.read_log(d / f"{c}.csv").df
        info = json.loads((d / f"{c}.truth.json").read_text())
        excl[c] = [x["row"] for x in info["glitches"]]
        excl_none[c] = []
    out, ke_all = _row(logs, excl)
    out_raw, ke_raw = _row(logs, excl_none)
    return "\n".join([HEADER, _fmt(f"{d} (glitch rows left out)", out, ke_all),
                      _fmt(f"{d} (raw, glitches in)", out_raw, ke_raw)])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dir", help="read <dir>/{sweep,load,long}.csv + truth instead of simulating")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args(argv)
    print(dir_table(a.dir) if a.dir else simulate_table(a.seed))


if __name__ == "__main__":
    main()
