"""Training, diagnosis and evaluation from the ripple alone against the same from the encoder
(issue 23 item 4, docs/ripple-training.md "Training, diagnosis and evaluation from the ripple alone"):
the commands of that section, run in one go, and their figures printed as its tables.

    PYTHONPATH=tools .venv/bin/python -m hpddo.studies.ripple_reference --json F [--work DIR]

1. twin benches in the ripple mode: `hpddo twin --protocol all --preset default --ripple-hz 10000
   --out bench` (sweep, load, long; with --long-time-scale S the long run alone at that time
   scale) and `hpddo twin --protocol validation ... --out val` (unseen, hot: never seen);
2. `hpddo train bench/*.csv` with the encoder and with `--reference ripple --ripples-per-rev 6
   --gear-ratio 4.4`: plain M2 (network seeds 1 and 2) and M2 with the effects the diagnosis
   names (EFFECTS);
3. each model scored against the encoder on every row of val (`hpddo evaluate --model M
   val/unseen.csv val/hot.csv`), and the plain ripple model against the ripple itself
   (`--reference ripple`, what a user without an encoder sees);
4. `hpddo diagnose bench/*.csv` with and without the ripple.

Every figure is read back from the commands' own metrics.json / diagnosis.json; the costs are
wall-clock seconds of each command (a process of its own) in this run, ripple against encoder.

    PYTHONPATH=tools .venv/bin/python -m hpddo.studies.ripple_reference --explain DIR [--json F]

reads the models of a finished `--work DIR` run back (no training) and says where M3 from the
ripple and from the encoder part (`explain`): the rows each trains on, each model's novelty gate
(its radius, the prototypes that serve at most 3 training rows) and, on the never-seen
recordings' no-load rows at duty 1.0, the gate's weight and the network's clamped residual; then
every model scored again with the gate fitted to the encoder's rows and to the ripple's, by the
gate's rule and by the rule before the core (every row a candidate for a prototype,
gate.fit(core_quantile=1.0)). M3 is recomputed in numpy (the header's network in float64, its
clamp and envelope, gate.weight as gate.h): with the header's own gate it gives the replay's RMSE.
"""
from __future__ import annotations

import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from .. import bench as bench_hw
from . import parser

EFFECTS = ("brush_drop", "thermal_ra", "magnet_thermal")  # what the diagnosis names from either reference
RIPPLE = ["--reference", "ripple", "--ripples-per-rev", str(bench_hw.HARDWARE.ripples_per_rev), "--gear-ratio",
          f"{bench_hw.HARDWARE.gear_ratio:g}"]  # the bench's (tools/hpddo/bench.py)
BENCH = ("sweep", "load", "long")
VAL = ("unseen", "hot")
# (label, trained from, effects, network seed)
MODELS = (("plain", "encoder", (), 1), ("plain", "ripple", (), 1), ("plain", "encoder", (), 2),
          ("plain", "ripple", (), 2), ("effects", "encoder", EFFECTS, 1), ("effects", "ripple", EFFECTS, 1))


def _run(argv: list) -> tuple[float, str]:
    """One hpddo command, `python -m hpddo ...` in a process of its own (the studies room sits
    below the CLI's): (wall seconds, its printed output)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(pathlib.Path(__file__).resolve().parents[2]), *filter(None, [os.environ.get("PYTHONPATH")])])}
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "hpddo", *map(str, argv)], capture_output=True, text=True, env=env)
    if p.returncode != 0:
        raise RuntimeError(f"hpddo {' '.join(map(str, argv))} failed ({p.returncode}):\n{p.stdout}{p.stderr}")
    return time.perf_counter() - t0, p.stdout


def benches(work: pathlib.Path, long_time_scale: float, time_scale: float = 1.0) -> tuple[list, list]:
    """The twin benches (time_scale: every run, for a quick check; long_time_scale: the long run's
    on top of it). At 1 and 1 these are the doc's two commands."""
    bench, val = work / "bench", work / "val"
    common = ["--preset", "default", "--ripple-hz", "10000", "--quiet"]
    if long_time_scale == 1.0 and time_scale == 1.0:
        _run(["twin", "--protocol", "all", *common, "--out", bench])
        _run(["twin", "--protocol", "validation", *common, "--out", val])
    else:
        for prot in BENCH:
            ts = time_scale * (long_time_scale if prot == "long" else 1.0)
            _run(["twin", "--protocol", prot, *common, "--time-scale", ts, "--out", bench])
        for prot in VAL:
            _run(["twin", "--protocol", prot, *common, "--time-scale", time_scale, "--out", val])
    return [bench / f"{p}.csv" for p in BENCH], [val / f"{p}.csv" for p in VAL]


def _ref_record(metrics: dict) -> dict | None:
    r = metrics.get("reference")
    if not r:
        return None
    return {"rows": r["rows"], "kept": r["kept"], "left_out": r["left_out"],
            "left_out_by_reason": r["left_out_by_reason"], "standing_labelled": r.get("standing_labelled", 0),
            "stall_labelled": r.get("stall_labelled", 0),
            "per_recording": {k: {"rows": v["rows"], "left_out_by_reason": v["left_out_by_reason"],
                                  "standing_labelled": v.get("standing_labelled", 0),
                                  "ke_prior_vs_per_rad": v["ke_prior_vs_per_rad"],
                                  "confidence_kept": v["confidence_kept"]} for k, v in r["recordings"].items()}}


def _diagnosis(d: dict) -> dict:
    """What the comparison of the two diagnoses needs from diagnosis.json."""
    ke = next((q for q in d["intervals"] if q.get("field") == "ke_vs_per_rad"), None)
    ra = d["ra_fit"].get("data_alone") or {}
    named = [m if isinstance(m, str) else m.get("effect") for m in d["missing_effects"]]
    shown = {}
    for r in d["ranking"]:
        if r.get("effect") not in named:
            continue
        q = next((q for q in d["intervals"] if q.get("quantity") == r["effect"] and q.get("determined")), None)
        text = r.get("shown") or ""
        if q is not None and q.get("lo") is not None:
            scale = 100.0 if q.get("unit") == "1/K" else 1.0  # %/K as the ranking shows it
            text += f" ({q['lo'] * scale:.3f}..{q['hi'] * scale:.3f})"
        if r.get("inclusion") is not None and (q is None or q.get("lo") is None):
            text += f", inclusion {r['inclusion']:.0%}"
        shown[r["effect"]] = text
    return {"named": named, "shown": shown, "ke_vs_per_rad": None if ke is None else ke["value"],
            "ra_data_ohm": [ra.get("value"), ra.get("lo"), ra.get("hi")], "noise_rpm": d["noise_rpm"],
            "told_apart": d.get("told_apart"), "confounded": d.get("confounded"), "verdict": d["verdict"]}


def run(work: pathlib.Path, long_time_scale: float = 1.0, quiet: bool = False, time_scale: float = 1.0,
        epochs: int | None = None) -> dict:
    say = (lambda *a: None) if quiet else (lambda *a: print(*a, file=sys.stderr, flush=True))
    t0 = time.perf_counter()
    logs, val = benches(work, long_time_scale, time_scale)
    say(f"benches in {time.perf_counter() - t0:.0f} s")
    out = {"long_time_scale": long_time_scale, "time_scale": time_scale, "epochs": epochs, "models": [], "costs_s": {}}
    for label, ref, effects, seed in MODELS:
        name = f"{label}_{ref}_s{seed}"
        mdir, edir = work / f"M_{name}", work / f"E_{name}"
        argv = ["train", *logs, "--out", mdir, "--seed", seed, "--quiet"]
        if epochs:
            argv += ["--epochs", epochs]
        if effects:
            argv += ["--effects", ",".join(effects)]
        if ref == "ripple":
            argv += RIPPLE
        t_train, _ = _run(argv)
        t_eval, _ = _run(["evaluate", "--model", mdir, *val, "--out", edir, "--quiet"])
        m = json.loads((mdir / "metrics.json").read_text())
        e = json.loads((edir / "metrics.json").read_text())
        rec = {"label": label, "from": ref, "effects": list(effects), "seed": seed,
               "ke_m2_vs_per_rad": m["identification"]["ke_m2_vs_per_rad"],
               "train_rows_m3": m["identification"]["train_rows"],
               "rmse_vs_encoder": {k: {c: e["rmse_rpm"][k][c] for c in (*VAL, "average")} for k in ("M2", "M3")},
               "fallback_share": {c: e["fallback_share"][c] for c in VAL},
               "gated_share": {c: e["gated_share"][c] for c in VAL},
               "reference": _ref_record(m), "train_s": t_train}
        out["models"].append(rec)
        out["costs_s"][f"train {name}"] = t_train
        say(f"{name}: train {t_train:.0f} s, M2 {rec['rmse_vs_encoder']['M2']['average']:.2f}, "
            f"M3 {rec['rmse_vs_encoder']['M3']['average']:.2f} RPM")
    # the plain ripple model scored against the ripple itself
    edir = work / "E_plain_ripple_s1_vs_ripple"
    _, _ = _run(["evaluate", "--model", work / "M_plain_ripple_s1", *val, "--out", edir, "--quiet", *RIPPLE])
    e = json.loads((edir / "metrics.json").read_text())
    out["scored_against_ripple"] = {"rmse": {k: {c: e["rmse_rpm"][k][c] for c in VAL} for k in ("M2", "M3")},
                                    "reference": _ref_record(e)}
    out["diagnosis"] = {}
    for ref in ("encoder", "ripple"):
        ddir = work / f"D_{ref}"
        t, _ = _run(["diagnose", *logs, "--out", ddir, "--quiet", *(RIPPLE if ref == "ripple" else [])])
        out["diagnosis"][ref] = _diagnosis(json.loads((ddir / "diagnosis.json").read_text()))
        out["costs_s"][f"diagnose {ref}"] = t
    out["total_s"] = time.perf_counter() - t0
    return out


def _pair(models, label, seed):
    enc = next(m for m in models if m["label"] == label and m["from"] == "encoder" and m["seed"] == seed)
    rip = next(m for m in models if m["label"] == label and m["from"] == "ripple" and m["seed"] == seed)
    return enc, rip


def tables(r: dict) -> str:
    lines = []
    ref = next(m for m in r["models"] if m["from"] == "ripple")["reference"]
    why = ", ".join(f"{k} {c}" for k, c in sorted(ref["left_out_by_reason"].items()))
    lines.append(f"rows left out of the training by the ripple: {ref['left_out']} of {ref['rows']} ({why}); "
                 f"{ref.get('standing_labelled', 0)} standing rows labelled 0 RPM from the back-EMF (drive off, no "
                 "current, |V| under 10 mV)")
    for name, pr in ref["per_recording"].items():
        w = ", ".join(f"{k} {c}" for k, c in sorted(pr["left_out_by_reason"].items())) or "none"
        ck = pr["confidence_kept"]
        ke = pr["ke_prior_vs_per_rad"]
        lines.append(f"  {name}: {pr['rows']} rows, left out: {w}; standing {pr.get('standing_labelled', 0)}; prior Ke "
                     + (f"{ke:.4f} V s/rad" if ke is not None else "none")
                     + f"; kept rows' confidence median {ck['median']:.2f}, min {ck['min']:.2f}")
    lines.append("")
    lines.append("| model | trained from | RMSE unseen | RMSE hot | average | ripple / encoder |")
    lines.append("|---|---|---|---|---|---|")
    for label, title in (("plain", "M2 (no effects)"), ("effects", "M2 with the named effects")):
        seeds = sorted({m["seed"] for m in r["models"] if m["label"] == label})
        for k, kt in (("M2", title), ("M3", "M3 on it")):
            rows = {"encoder": [], "ripple": []}
            for s in seeds:
                enc, rip = _pair(r["models"], label, s)
                rows["encoder"].append(enc["rmse_vs_encoder"][k])
                rows["ripple"].append(rip["rmse_vs_encoder"][k])
                if k == "M2":
                    break  # M2 does not depend on the network's seed
            for src in ("encoder", "ripple"):
                cells = [" / ".join(f"{x[c]:.2f}" for x in rows[src]) for c in (*VAL, "average")]
                ratio = ""
                if src == "ripple":
                    ratio = " / ".join(f"{a['average'] / b['average'] - 1:+.1%}"
                                       for a, b in zip(rows["ripple"], rows["encoder"]))
                seed_note = f" (seed {' / '.join(map(str, seeds))})" if k == "M3" and len(rows[src]) > 1 else ""
                lines.append(f"| {kt} | {src}{seed_note} | " + " | ".join(cells) + f" | {ratio} |")
    for label in ("plain", "effects"):
        enc, rip = _pair(r["models"], label, 1)
        lines.append(f"{label}: Ke of M2 {enc['ke_m2_vs_per_rad']:.4f} (encoder) / {rip['ke_m2_vs_per_rad']:.4f} "
                     f"(ripple) V s/rad; M3 trained on {enc['train_rows_m3']} / {rip['train_rows_m3']} rows; "
                     f"fallback on unseen {enc['fallback_share']['unseen']:.1%} / {rip['fallback_share']['unseen']:.1%}, "
                     f"hot {enc['fallback_share']['hot']:.1%} / {rip['fallback_share']['hot']:.1%}")
    lines.append("")
    d = r["diagnosis"]
    lines.append(f"diagnosis names: encoder {', '.join(d['encoder']['named']) or 'nothing'}; "
                 f"ripple {', '.join(d['ripple']['named']) or 'nothing'}")
    lines.append("| | encoder | ripple |")
    lines.append("|---|---|---|")
    for eff in dict.fromkeys(d["encoder"]["named"] + d["ripple"]["named"]):
        lines.append(f"| {eff} | {d['encoder']['shown'].get(eff, '-')} | {d['ripple']['shown'].get(eff, '-')} |")
    lines.append(f"| Ke | {d['encoder']['ke_vs_per_rad']:.4f} V s/rad | {d['ripple']['ke_vs_per_rad']:.4f} V s/rad |")
    lines.append("| Ra the data support | " + " | ".join(
        f"{x['ra_data_ohm'][0]:.2f} ohm ({x['ra_data_ohm'][1]:.2f}..{x['ra_data_ohm'][2]:.2f})"
        for x in (d["encoder"], d["ripple"])) + " |")
    lines.append(f"| noise floor | {d['encoder']['noise_rpm']:.2f} RPM | {d['ripple']['noise_rpm']:.2f} RPM |")
    for src in ("encoder", "ripple"):
        lines.append(f"told apart ({src}): {json.dumps(d[src]['told_apart'])}; confounded: {json.dumps(d[src]['confounded'])}")
    lines.append("")
    s = r["scored_against_ripple"]
    lines.append("scored against the ripple (plain ripple model): M2 " + " / ".join(f"{s['rmse']['M2'][c]:.2f}" for c in VAL)
                 + ", M3 " + " / ".join(f"{s['rmse']['M3'][c]:.2f}" for c in VAL) + " RPM on " + " / ".join(VAL))
    for name, pr in s["reference"]["per_recording"].items():
        w = ", ".join(f"{k} {c}" for k, c in sorted(pr["left_out_by_reason"].items())) or "none"
        lines.append(f"  left out of the score: {name} {sum(pr['left_out_by_reason'].values())} of {pr['rows']} ({w})")
    costs = ("costs: train {train plain_ripple_s1:.0f} s with the ripple, {train plain_encoder_s1:.0f} s with the "
             "encoder; diagnose {diagnose ripple:.0f} s against {diagnose encoder:.0f} s").format_map(r["costs_s"])
    return "\n".join([*lines, "", f"{costs}; the whole study {r['total_s']:.0f} s"])


# (duty, load) of hot's never-seen rows that no training row resembles, where the two M3's gates decide
# (docs/ripple-training.md, "Why the two gates agree")
EXPLAIN_POINT = (1.0, 0)


def _m3(md, gd, x: np.ndarray, n2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n_M3 of a model header's network with the gate gd, by train.correction (observer.h's rules,
    the network in float64); (n_M3, w, the network's clamped residual on every row, gated or not)."""
    from ..model import network, train
    res = train.Residual(scaler=network.Scaler(mean_=md.scaler_mean.astype(float), scale_=md.scaler_scale.astype(float)),
                         mlp=network.Network(coefs_=[w_.astype(float).T for w_, _ in md.layers],
                                             intercepts_=[b_.astype(float) for _, b_ in md.layers]),
                         clamp_rpm=float(md.clamp_rpm), env_lo=md.env_lo, env_hi=md.env_hi, gate=gd, n_train=0,
                         loss_curve=[])
    corr, w = train.correction(res, x)
    r = np.clip(np.nan_to_num(res.mlp.predict(res.scaler.transform(x))), -res.clamp_rpm, res.clamp_rpm)
    return n2 + corr, w, r


def explain(work: pathlib.Path) -> dict:
    """Why M3 from the ripple and from the encoder part on the never-seen recordings, from the models of
    a finished run (see the module text)."""
    from ..logs import dataset
    from ..model import export, gate as gate_mod, train
    from ..ripple.reference import Ripple

    work = pathlib.Path(work)
    logs, val = [work / "bench" / f"{p}.csv" for p in BENCH], [work / "val" / f"{p}.csv" for p in VAL]
    recs = {"encoder": dataset.load_recordings(logs),
            "ripple": dataset.load_recordings(logs, reference=Ripple(bench_hw.HARDWARE.ripples_per_rev,
                                                                     bench_hw.HARDWARE.gear_ratio))}
    vrecs = [dataset.load_recording(v, train_fraction=0.0) for v in val]
    # the training rows each reference labels, by seq: those only the encoder labels, and how many are
    # the first window after a change of duty
    only = {}
    for re_, rr in zip(recs["encoder"], recs["ripple"]):
        def labelled(r):
            d = r.df.iloc[: r.n_train]
            return set(d["seq"][np.isfinite(d["rpm_ref"].to_numpy(float))])
        e_only = sorted(labelled(re_) - labelled(rr))
        duty = re_.df.set_index("seq")["duty"]
        step = [int(s) for s in e_only if s == duty.index[0] or duty.get(s) != duty.shift(1).get(s)]
        only[re_.name] = {"encoder_only": len(e_only), "first_after_duty_change": len(step),
                          "ripple_only": len(labelled(rr) - labelled(re_))}
    out = {"point": {"duty": EXPLAIN_POINT[0], "load": EXPLAIN_POINT[1]}, "rows_only_one_labels": only, "models": {}}
    models = {f"{label}_{ref}_s{seed}": (label, ref) for label, ref, _, seed in MODELS}
    hdr = {n: export.read_model_header((work / f"M_{n}" / "model_default.h").read_text()) for n in models}
    for label in dict.fromkeys(lab for lab, _ in models.values()):
        first = {ref: next(n for n, (lab, r) in models.items() if lab == label and r == ref) for ref in ("encoder", "ripple")}
        xs = {ref: train.labelled_rows(recs[ref], hdr[first[ref]].physics)[0] for ref in first}
        gates = {f"{rule} on the {ref}'s rows": gate_mod.fit(xs[ref], core_quantile=cq)
                 for rule, cq in (("core", None), ("every row", 1.0)) for ref in first}
        for n, (lab, ref) in models.items():
            if lab != label:
                continue
            md = hdr[n]
            z = gate_mod.scaled(md.gate, xs[ref])
            near = np.argmin(np.stack([gate_mod._sq_dist(z, p) for p in md.gate.prototypes], axis=1), axis=1)
            rec = {"train_rows": int(len(xs[ref])), "r_in_sq": float(md.gate.r_in_sq),
                   "prototypes_serving_at_most_3_rows": int((np.bincount(near, minlength=md.gate.count) <= 3).sum()),
                   "rmse": {}}
            for gname, gd in {"own": md.gate, **gates}.items():
                cell, at = {}, {}
                for v, vr in zip(VAL, vrecs):
                    x, n2 = train.features(vr, md.physics)
                    est, w, r = _m3(md, gd, x, n2)
                    err = est - vr.df["rpm_ref"].to_numpy(float)
                    cell[v] = float(np.sqrt(np.nanmean(err ** 2)))
                    sel = ((vr.df["duty"] == EXPLAIN_POINT[0]) & (vr.df["load"] == EXPLAIN_POINT[1])).to_numpy()
                    if sel.any():
                        at[v] = {"rows": int(sel.sum()), "rmse": float(np.sqrt(np.nanmean(err[sel] ** 2))),
                                 "w_mean": float(w[sel].mean()), "clamped_residual_rpm": float(r[sel].mean())}
                cell["average"] = float(np.mean([cell[v] for v in VAL]))
                rec["rmse"][gname] = {**cell, "r_in_sq": float(gd.r_in_sq), "at_point": at}
            out["models"][n] = rec
    return out


def explain_text(r: dict) -> str:
    pt = r["point"]
    lines = ["training rows the encoder labels and the ripple leaves out: " + "; ".join(
        f"{k} {v['encoder_only']} ({v['first_after_duty_change']} the first window of the recording or after a change of duty; "
        f"{v['ripple_only']} the other way)" for k, v in r["rows_only_one_labels"].items())]
    for n, m in r["models"].items():
        lines.append(f"{n}: {m['train_rows']} rows, gate r_in_sq {m['r_in_sq']:.4f}, "
                     f"{m['prototypes_serving_at_most_3_rows']} of its prototypes serve at most 3 training rows")
        for g, c in m["rmse"].items():
            at = "; ".join(f"{v} {a['rows']} rows at duty {pt['duty']:g} load {pt['load']}: RMSE {a['rmse']:.2f}, "
                           f"w {a['w_mean']:.3f}, clamped residual {a['clamped_residual_rpm']:+.2f} RPM"
                           for v, a in c["at_point"].items())
            lines.append(f"  gate {g} (r_in_sq {c['r_in_sq']:.4f}): M3 unseen {c['unseen']:.2f}, hot {c['hot']:.2f}, "
                         f"average {c['average']:.2f}; {at}")
    pairs = sorted({n.replace("ripple", "encoder") for n in r["models"] if "ripple" in n})
    for e in pairs:
        rp = e.replace("encoder", "ripple")
        if rp not in r["models"] or e not in r["models"]:
            continue
        cells = ", ".join(f"{g} {r['models'][rp]['rmse'][g]['average'] / r['models'][e]['rmse'][g]['average'] - 1:+.1%}"
                          for g in r["models"][e]["rmse"] if g != "own")
        own = r["models"][rp]["rmse"]["own"]["average"] / r["models"][e]["rmse"]["own"]["average"] - 1
        lines.append(f"{rp} / {e}: own gates {own:+.1%}; both with the gate {cells}")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = parser("ripple_reference", __doc__)
    ap.add_argument("--work", type=pathlib.Path, help="keep the benches, models and reports here (new or empty); "
                    "default a temporary folder, removed after")
    ap.add_argument("--long-time-scale", type=float, default=1.0, help="the long run's time scale (default 1: 60 min)")
    ap.add_argument("--time-scale", type=float, default=1.0, help="every twin run's time scale, for a quick check "
                    "(default 1: the doc's figures)")
    ap.add_argument("--epochs", type=int, default=None, help="M3's epochs (default hpddo train's), for a quick check")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--explain", type=pathlib.Path, metavar="DIR", help="read the models of a finished --work DIR "
                    "back and say where M3 from the ripple and from the encoder part (no training)")
    args = ap.parse_args(argv)
    if args.explain:
        r = explain(args.explain)
        print(explain_text(r))
        if args.json:
            args.json.write_text(json.dumps(r, indent=1))
        return 0
    work = args.work or pathlib.Path(tempfile.mkdtemp(prefix="hpddo-ripple-reference-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        r = run(work, args.long_time_scale, args.quiet, args.time_scale, args.epochs)
    finally:
        if args.work is None:
            shutil.rmtree(work, ignore_errors=True)
    print(tables(r))
    if args.json:
        args.json.write_text(json.dumps(r, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
