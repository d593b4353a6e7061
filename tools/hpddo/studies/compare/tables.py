"""The paper's tables on these recordings: 7 (chronological, never seen, leave one out), 8 (shuffled CV), 9 (architectures), 10 (features) and the out-of-distribution test with eq. 26."""
from __future__ import annotations

import numpy as np

from ...evaluation import baseline, replay
from ...logs import dataset
from ...model import export, identify
from ...evaluation import metrics as metrics_mod
from ...model import physics as ph
from ...model import train as train_mod
from .config import CV_FOLDS, EQ26_FLOAT64_TOLERANCE_RPM, EQ26_TOLERANCE_RPM, FEATURE_SETS, PAPER, label, param_count
from .methods import Fitted, _physics, finish_fit, m3_variants, reference
from .observers import run_observers, write_mlp
from . import ripple_peer


def rmse_table(recs, estimates: list, masks=None) -> dict:
    """{method: {condition: rmse, "average": mean over conditions}} pooled per condition,
    over the rows of each mask (default every row) with an encoder reading."""
    per = {}
    for k, (r, est) in enumerate(zip(recs, estimates)):
        ref = reference(r)
        mask = np.ones(r.n, bool) if masks is None else masks[k]
        for m, v in est.items():
            per.setdefault(m, {}).setdefault(r.name, []).append((np.asarray(v, float) - ref)[mask])
    out = {}
    for m, conds in per.items():
        vals = {c: metrics_mod.rmse(np.concatenate(e)) for c, e in conds.items()}
        out[m] = {**{c: metrics_mod.figure(v) for c, v in vals.items()},
                  "average": metrics_mod.figure(float(np.mean(list(vals.values()))))}
    return out


def eq26(n3: np.ndarray, n2: np.ndarray, ref: np.ndarray, clamp: float, tol: float = EQ26_FLOAT64_TOLERANCE_RPM) -> dict:
    """Eq. 26, |n_M3 - n| <= |n_M2 - n| + clamp, on every labelled sample: the samples
    checked, the violations and the largest excess (RPM)."""
    ok = np.isfinite(ref) & np.isfinite(n3) & np.isfinite(n2)
    excess = np.abs(n3[ok] - ref[ok]) - (np.abs(n2[ok] - ref[ok]) + clamp)
    return {"samples": int(ok.sum()), "violations": int(np.sum(excess > tol)),
            "largest_excess_rpm": metrics_mod.figure(float(excess.max())) if ok.any() else None,
            "clamp_rpm": metrics_mod.figure(clamp), "tolerance_rpm": tol}


def replay_m3(recs, vrecs, m1, m2, fit: Fitted, gated: bool, work, cfg) -> dict:
    """The board observer, compiled against the chronological M3 with (or without) the
    gate, replayed on the chronological split and the never-seen recordings:
    {(model, part): [estimates DataFrame per recording]}."""
    from ...pipeline import model_data
    name = "M3 gated" if gated else "M3"
    model = model_data(m1, m2, fit.as_residual(gated))
    mname = "compare_gated" if gated else "compare_nogate"
    mdir = work / "models" / mname
    mdir.mkdir(parents=True, exist_ok=True)
    (mdir / f"model_{mname}.h").write_text(export.model_header(model, mname, {
        "command": cfg.command, "seed": cfg.seed, "note": "hpddo compare, chronological training part"}))
    rdir = work / "replay" / mname
    exe = replay.build(mdir, mname, rdir / "replay")
    out = {}
    for part, rs, split in (("chronological", recs, None), ("validation", vrecs, 0.0)):
        d = rdir / part
        (d / "logs").mkdir(parents=True, exist_ok=True)
        (d / "estimates").mkdir(parents=True, exist_ok=True)
        clean = [dataset.write_clean(r, d / "logs" / f"{r.file_stem}.csv") for r in rs]
        out[(name, part)] = replay.run(exe, clean, d / "estimates", split) if rs else []
    return out


def table7_chrono_and_validation(recs, vrecs, m2, m2e, fit: Fitted, replays: dict, tuned, mlp_file, work,
                                 ripple: dict | None = None):
    """Chronological test parts and never-seen recordings: M1, M2, M3 (with and without
    the gate) by the native replay of the board observer, the rest as documented.
    ripple: None, or {recording name: ripple_peer.RippleSpeeds} of every recording (the
    ripple rows and their coverage)."""
    est = {"chronological": [dict() for _ in recs], "validation": [dict() for _ in vrecs]}
    native_check = {}
    float64_only = []
    for name in ("M3 gated", "M3"):
        gated = name == "M3 gated"
        for part, rs in (("chronological", recs), ("validation", vrecs)):
            if (name, part) not in replays:  # --quick: one native model, the other by the float64 rules
                float64_only.append(name)
                for k, r in enumerate(rs):
                    x, n2 = train_mod.features(r, m2)
                    est[part][k][name] = n2 + train_mod.correction(fit.as_residual(gated), x)[0]
                continue
            for k, (r, f) in enumerate(zip(rs, replays[(name, part)])):
                e = est[part][k]
                e[name] = f["rpm_m3"].to_numpy(float)
                e["M1"], e["M2"] = f["rpm_m1"].to_numpy(float), f["rpm_m2"].to_numpy(float)
                # the float64 rules used elsewhere, against the board's float32
                x, n2 = train_mod.features(r, m2)
                py = n2 + train_mod.correction(fit.as_residual(gated), x)[0]
                d = np.abs(py - e[name])
                native_check.setdefault(f"{name}: largest |float64 rules - native replay| (RPM)", []).append(
                    float(np.nanmax(d)) if np.isfinite(d).any() else 0.0)
                ref = reference(r)
                mask = np.arange(r.n) >= r.n_train
                chk = eq26(e[name][mask], e["M2"][mask], ref[mask], fit.clamp_rpm, EQ26_TOLERANCE_RPM)
                native_check.setdefault(f"eq. 26 on the native {name}", []).append(chk)
    for key in list(native_check):
        v = native_check[key]
        if isinstance(v[0], float):
            native_check[key] = metrics_mod.figure(max(v))
        else:
            native_check[key] = {"samples": sum(c["samples"] for c in v), "violations": sum(c["violations"] for c in v),
                                 "clamp_rpm": v[0]["clamp_rpm"], "tolerance_rpm": EQ26_TOLERANCE_RPM}
    lookup = baseline.Lookup.fit(recs)
    for part, rs in (("chronological", recs), ("validation", vrecs)):
        obs = run_observers(tuned, rs, work / "observers" / part, mlp_file, ripple) if rs else []
        for k, r in enumerate(rs):
            e = est[part][k]
            if m2e is not None:
                e["M2 + effects"] = _physics(r, m2e)
            e.update(obs[k])
            e["lookup"] = lookup.predict_rows(r)
            if ripple is not None:
                e.update(ripple_peer.estimates(ripple[r.name], e["M2"]))
    out = {"title": "Table 7: RMSE (RPM) of every method",
           "methods": method_order(m2e is not None, ripple is not None),
           "chronological": {"what": "the held-out chronological 20 % of each recording (the paper's Table 7)",
                             "rmse_rpm": order(rmse_table(recs, est["chronological"],
                                                          [np.arange(r.n) >= r.n_train for r in recs]),
                                               m2e is not None)},
           "paper": PAPER["table7"],
           "sources": {"M1, M2, " + ("M3 gated" if float64_only else "M3, M3 gated"):
                       "native replay of the board observer (host/replay.cpp), float32",
                       **({"M3": "--quick: the observer's rules in float64 (train.correction)"} if float64_only else {}),
                       "EKF, SMO, pure NN": "native replay of host/compare (compare_observers): EKF and SMO in "
                                            "double, the network in float32",
                       "M2 + effects": "physics.physics_rpm in float64 with the observer's lag and thermal rules",
                       "lookup": "hpddo.evaluation.baseline.Lookup of the training rows"}}
    if vrecs:
        out["validation"] = {"what": "every row of recordings no training saw (--validation); models of the "
                                     "chronological training part",
                             "rmse_rpm": order(rmse_table(vrecs, est["validation"]), m2e is not None)}
    if ripple is not None:
        out["sources"].update(RIPPLE_SOURCES)
        out["chronological"].update(ripple_peer.coverage(
            recs, [ripple[r.name] for r in recs], [np.arange(r.n) >= r.n_train for r in recs]))
        if vrecs:
            out["validation"].update(ripple_peer.coverage(vrecs, [ripple[r.name] for r in vrecs]))
    return out, native_check


RIPPLE_SOURCES = {
    ripple_peer.ALONE: "hpddo.ripple on the current bursts beside each log, its back-EMF prior the one "
                       "ripple_prior names (Ke calibrated from the ripple, no encoder; --ke-vs-per-rad's; or "
                       "--prior-model's M2); RMSE over the rows with a confident count (ripple_coverage)",
    ripple_peer.FUSED: "the ripple count with M2 as its prior where confident, M2 elsewhere; every row",
    ripple_peer.EKF: "native replay of host/compare's EKF (as tuned above) with the same count as a second "
                     "measurement of the speed, weighted by its uncertainty (hpddo.ripple.count.count_sd_rpm); "
                     "every row"}


def method_order(effects: bool, ripple: bool = False) -> list:
    return (["M1", "M2"] + (["M2 + effects"] if effects else []) + ["EKF", "SMO", "pure NN", "M3", "M3 gated"]
            + (list(ripple_peer.METHODS) if ripple else []) + ["lookup"])


def order(t: dict, effects: bool) -> dict:
    return {m: t[m] for m in method_order(effects, ripple=True) if m in t}


def table7_loro(whole, loro, tuned_loro, trainer, m1, m2e, cfg, work, ra, ripple: dict | None = None) -> dict:
    """Leave one recording out: for each recording, every method identified, trained and
    tuned on the training parts of the others, scored on every row of it (M3 by the
    float64 rules; the ripple counts as in the chronological table, their prior the
    chronological M2, fused with this M2)."""
    h = label(cfg.hidden)
    rmse = {}
    for k, rec in enumerate(whole):
        others, p, xo, eo = loro[rec.name]
        fit = finish_fit(range(5), trainer.get(("M3", h, f"leave out {rec.name}")), xo, eo, gate=True)
        nn = trainer.get(("pure NN", h, f"leave out {rec.name}"))
        sub = work / "leave_one_out" / dataset.safe_name(rec.name)
        sub.mkdir(parents=True, exist_ok=True)
        obs = run_observers(tuned_loro[rec.name], [rec], sub, write_mlp(nn[0], nn[1], sub / "pure_nn.mlp"), ripple)[0]
        x, n2 = train_mod.features(rec, p)
        v = m3_variants(fit, x, n2)
        est = {"M1": _physics(rec, m1), "M2": n2}
        if m2e is not None:
            from ...model import effects
            est["M2 + effects"] = _physics(rec, effects.identify(others, p, cfg.effects))
        est.update(obs)
        est["M3"] = v["clamped + fallback"]
        est["M3 gated"] = v["clamped + fallback + gate"]
        est["lookup"] = baseline.Lookup.fit(others).predict_rows(rec)
        if ripple is not None:
            est.update(ripple_peer.estimates(ripple[rec.name], n2))
        for m, val in rmse_table([rec], [est]).items():
            rmse.setdefault(m, {})[rec.name] = val[rec.name]
    for m in rmse:
        rmse[m]["average"] = metrics_mod.figure(float(np.mean([v for v in rmse[m].values()])))
    out = {"what": "every row of each recording, everything identified, trained and tuned on the training parts "
                   "of the others (M1, M2, M3 by the float64 rules of the observer)",
           "rmse_rpm": order(rmse, m2e is not None)}
    if ripple is not None:
        out.update(ripple_peer.coverage(whole, [ripple[r.name] for r in whole]))
    return out


def cv_folds(recs, ra, seed: int) -> dict:
    """Shuffled 5-fold cross-validation over every labelled row of every recording (the
    features computed on the whole recordings, lags included, as a shuffled split of a
    feature table does): per fold, Ke (eq. 20) and the network on the other folds."""
    rows = []
    for k, r in enumerate(recs):
        ref = reference(r)
        idx = np.flatnonzero(np.isfinite(ref))
        rows.append(np.column_stack([np.full(len(idx), k), idx]))
    rows = np.concatenate(rows)
    perm = np.random.default_rng(seed).permutation(len(rows))
    fold_of = np.empty(len(rows), int)
    fold_of[perm] = np.arange(len(rows)) % CV_FOLDS
    v = np.concatenate([r.df["v_V"].to_numpy(float) for r in recs])
    folds = []
    offsets = np.cumsum([0] + [r.n for r in recs])
    flat_v = v
    flat_i = np.concatenate([r.df["i_A"].to_numpy(float) for r in recs])
    flat_ref = np.concatenate([reference(r) for r in recs])
    glob = offsets[rows[:, 0]] + rows[:, 1]
    for f in range(CV_FOLDS):
        tr = glob[fold_of != f]
        keep = tr[flat_ref[tr] > identify.MIN_RPM]
        ke = identify.ke_eq20(flat_v[keep], flat_i[keep], flat_ref[keep], ra)
        identify.check_ke(ke, flat_v[keep], flat_i[keep], ra)
        p = ph.PhysicsParams(ra_ohm=ra, ke_vs_per_rad=ke, t_ref_C=identify.reference_temp_C(recs),
                             t_amb_C=identify.ambient_C(recs))
        xs, n2s = zip(*[train_mod.features(r, p) for r in recs])
        x, n2 = np.concatenate(xs), np.concatenate(n2s)
        e = flat_ref - n2
        ok = tr[np.isfinite(x[tr]).all(axis=1)]
        folds.append({"p": p, "x": x[ok], "e": e[ok], "test": glob[fold_of == f], "x_all": x, "n2_all": n2})
    return {"folds": folds, "offsets": offsets, "rows": len(rows)}


def make_table8(recs, cv, trainer, fit_chrono: Fitted, m2, cfg) -> dict:
    h = label(cfg.hidden)
    flat_ref = np.concatenate([reference(r) for r in recs])
    est = np.full(len(flat_ref), np.nan)
    for k, fold in enumerate(cv["folds"]):
        fit = finish_fit(range(5), trainer.get(("M3", h, f"CV fold {k + 1}")), fold["x"], fold["e"])
        t = fold["test"]
        est[t] = m3_variants(fit, fold["x_all"][t], fold["n2_all"][t])["clamped + fallback"]
    off = cv["offsets"]
    cv_est = [{"shuffled 5-fold CV": est[off[k]:off[k + 1]]} for k in range(len(recs))]
    cv_rm = rmse_table(recs, cv_est)
    chrono = []
    for r in recs:
        x, n2 = train_mod.features(r, m2)
        chrono.append({"chronological 80/20": m3_variants(fit_chrono, x, n2)["clamped + fallback"]})
    ch_rm = rmse_table(recs, chrono, [np.arange(r.n) >= r.n_train for r in recs])
    return {"title": f"Table 8: M3 {h} RMSE (RPM) under both evaluation protocols",
            "rmse_rpm": {**cv_rm, **ch_rm}, "paper": PAPER["table8"],
            "what": "M3 (clamp and envelope, no gate), float64 rules. CV: every labelled row in 5 shuffled folds, "
                    "Ke and the network fitted on 4, scored on the 5th, pooled per condition; chronological: "
                    "the last 20 % of each recording, trained on the first 80 %"}


def make_table9(recs, trainer, m2, x_tr, e_tr, cfg) -> dict:
    rows = {}
    masks = [np.arange(r.n) >= r.n_train for r in recs]
    feats = [train_mod.features(r, m2) for r in recs]
    for hh in cfg.architectures:
        fit = finish_fit(range(5), trainer.get(("M3", label(hh), "chronological")), x_tr, e_tr)
        est = [{"M3": m3_variants(fit, x, n2)["clamped + fallback"]} for x, n2 in feats]
        rm = rmse_table(recs, est, masks)["M3"]
        n = param_count(hh)
        rows[label(hh)] = {"params": n, "bytes": 4 * n, "memory_kB": round(4 * n / 1024, 1), "rmse_rpm": rm}
    return {"title": "Table 9: architecture ablation, M3 RMSE (RPM) on the chronological test parts",
            "rows": rows, "paper": PAPER["table9"], "paper_columns": PAPER["table9_columns"],
            "what": "M3 (clamp and envelope, no gate), float64 rules; params: weights and biases of the network; "
                    "bytes: 4 per float32 parameter (the network alone, without scaler, envelope or gate)"}


def make_table10(recs, trainer, m2, x_tr, e_tr, cfg) -> dict:
    h = label(cfg.hidden)
    masks = [np.arange(r.n) >= r.n_train for r in recs]
    feats = [train_mod.features(r, m2) for r in recs]
    rows = {}
    for name, cols in FEATURE_SETS.items():
        key = ("M3", h, "chronological") if name == "full" else ("M3", h, name)
        fit = finish_fit(cols, trainer.get(key), x_tr, e_tr)
        est = [{"M3": m3_variants(fit, x, n2)["clamped + fallback"]} for x, n2 in feats]
        rows[name] = {"features": [train_mod.FEATURES[c] for c in cols],
                      "rmse_rpm": rmse_table(recs, est, masks)["M3"]}
    return {"title": f"Table 10: feature ablation with the {h} network, M3 RMSE (RPM)", "rows": rows,
            "paper": PAPER["table10"],
            "what": "M3 (clamp and envelope, no gate), float64 rules, on the chronological test parts; the "
                    "correction is still added to n_M2 in every row"}


def make_ood(recs, whole, ood, trainer, cfg) -> dict:
    """Section 4.10: trained on one recording's training part, tested on every row of each
    other recording; the four safeguard levels, their shares and eq. 26 on every sample."""
    h = label(cfg.hidden)
    runs = {}
    for r in recs:
        p, xo, eo = ood[r.name]
        fit = finish_fit(range(5), trainer.get(("M3", h, f"trained on {r.name} only")), xo, eo, gate=True)
        tests = [w for w in whole if w.name != r.name]
        est, shares, checks = [], {}, {}
        for w in tests:
            x, n2 = train_mod.features(w, p)
            v = m3_variants(fit, x, n2)
            ref = reference(w)
            lab = np.isfinite(ref)
            e = {"M2 (physics only)": n2}
            e.update({k: v[k] for k in ("unconstrained", "clamped", "clamped + fallback", "clamped + fallback + gate")})
            est.append(e)
            shares[w.name] = {"clamped": metrics_mod.figure(float(np.mean(np.abs(v["r"][lab]) > fit.clamp_rpm))),
                              "fallback": metrics_mod.figure(float(np.mean(~v["inside"][lab]))),
                              "gated": metrics_mod.figure(float(np.mean(v["inside"][lab] & (v["w"][lab] < 1))))}
            for k in ("unconstrained", "clamped", "clamped + fallback", "clamped + fallback + gate"):
                checks.setdefault(k, []).append(eq26(v[k], n2, ref, fit.clamp_rpm))
        rm = rmse_table(tests, est)
        eq = {k: {"samples": sum(c["samples"] for c in v), "violations": sum(c["violations"] for c in v),
                  "largest_excess_rpm": max((c["largest_excess_rpm"] for c in v if c["largest_excess_rpm"] is not None),
                                            default=None)}
              for k, v in checks.items()}
        runs[r.name] = {"trained_on": r.name, "train_rows": fit.n_train, "clamp_rpm": metrics_mod.figure(fit.clamp_rpm),
                        "rmse_rpm": rm, "shares": shares, "eq26": eq}
    return {"title": "Section 4.10: out-of-distribution stress test, RMSE (RPM)", "runs": runs,
            "paper": PAPER["ood"],
            "what": "M2 and M3 identified and trained on the training part of one recording, scored on every row "
                    "of each other recording; shares: of the labelled rows, the raw residual beyond the clamp, "
                    "outside the envelope (fallback to M2), inside but faded by the gate; eq26: "
                    "|n_M3 - n| <= |n_M2 - n| + clamp on every labelled sample (float64 rules; the unconstrained "
                    "network has no bound, its count shows what the clamp prevents)"}
