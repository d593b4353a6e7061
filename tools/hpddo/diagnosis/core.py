"""The diagnosis: model against measurements, residual analysis, ranking of the missing
effects, verdict, and the error before and after adding them (physics and hybrid)."""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from .. import dataset, identify
from ..errors import InputError
from .. import effects as fx
from .. import physics as ph
from ..train import TrainConfig, TrainingError, features, train_residual
from . import analysis, ranking

MIN_HELD_OUT_ROWS = 8  # fewer held-out labelled rows cannot rank anything
HYBRID_ITER = 150  # training iterations of the hybrid in the diagnosis (gen_weights: 2000)


@dataclasses.dataclass
class Options:
    effects: tuple = ()          # effects already in the model under test
    ra_ohm: float | None = None
    bootstrap: int = ranking.BOOTSTRAP
    hybrid: bool = True
    hybrid_iter: int = HYBRID_ITER
    seed: int = 1
    glitch_filter: bool = True


def _rmse_by_condition(rows, res) -> dict:
    """RMSE on the test parts per condition (all test rows with an encoder reading, as the
    native replay counts them) and their average over conditions."""
    se, cnt = {}, {}
    for r, e in zip(rows, res):
        m = np.isfinite(r.ref) & (np.arange(r.rec.n) >= r.rec.n_train) & np.isfinite(e)
        se[r.rec.name] = se.get(r.rec.name, 0.0) + float(np.sum(e[m] ** 2))
        cnt[r.rec.name] = cnt.get(r.rec.name, 0) + int(m.sum())
    out = {c: float(np.sqrt(se[c] / cnt[c])) if cnt[c] else float("nan") for c in se}
    out["average"] = float(np.mean([v for v in out.values()])) if out else float("nan")
    return out


def _hybrid(recs, p, cfg_iter, seed):
    """M3 on top of physics p: trained on the training rows; estimates for every row with
    the observer's clamp and envelope fallback."""
    res = train_residual(recs, p, TrainConfig(hidden=(16, 8), max_iter=cfg_iter, seed=seed, progress=False))
    out = []
    for r in recs:
        x, n2 = features(r, p)
        ok = np.all(np.isfinite(x), axis=1)
        inside = ok & np.all((x >= res.env_lo) & (x <= res.env_hi), axis=1)
        corr = np.zeros(r.n)
        if inside.any():
            corr[inside] = np.clip(res.mlp.predict(res.scaler.transform(x[inside])), -res.clamp_rpm, res.clamp_rpm)
        out.append(n2 + corr)
    return out


# Keys that _entry derives from the parameters (the rest are the caller's).
_ENTRY_KEYS = ("effect", "params", "shown", "unit", "plausible", "plausibility", "meaning")
# The copper-plus-magnets reading is taken when its held-out mean squared error is at most
# this many noise variances above the freely fitted one's.
MATERIAL_SLACK = 0.5


def _entry(name, p, **kw):
    eff = fx.LIBRARY[name]
    val = getattr(p, eff.field)
    ok, text = eff.plausibility(val)
    e = {"effect": name, "params": {eff.field: val}, "shown": eff.show(val), "unit": eff.unit,
         "plausible": ok, "plausibility": text, "meaning": eff.meaning}
    if eff.thermal and p.thermal_enabled():
        e["params"].update(th_r_K_per_W=p.th_r_K_per_W, th_tau_s=p.th_tau_s)
    e.update(kw)
    return e


def diagnose(paths, opt: Options) -> dict:
    t0 = time.perf_counter()
    recs = dataset.load_recordings(paths, glitch_filter=opt.glitch_filter)
    ra, ra_source = identify.ra_from_logs(recs, opt.ra_ohm)
    m2 = identify.m2_params(recs, ra)
    given = list(fx.check_names(opt.effects))
    rows = [fx.rows_of(r) for r in recs]
    held_out = sum(int(r.test.sum()) for r in rows)
    if held_out < MIN_HELD_OUT_ROWS:
        raise InputError(f"only {held_out} held-out rows with rpm_ref > {fx.MIN_RPM} RPM in "
                         f"{', '.join(str(r.source) for r in recs)}: the diagnosis scores every effect on rows "
                         f"not used to fit it and needs at least {MIN_HELD_OUT_ROWS}; give longer recordings")
    d = ranking.make_data(rows)

    # the model under test, as gen_weights builds it
    model = fx.identify(recs, m2, given) if given else m2
    res_model = ranking.residuals(d, model)
    # the same model with Ke by least squares: the reference of the ranking
    base = fx.fit(rows, m2, given)
    res_base = ranking.residuals(d, base)
    sigma2 = ranking.noise_var(d, res_base)
    mse_base = ranking.held_out_mse(d, res_base)

    ident = {c: ranking.identifiability(d, base, c, sigma2, given) for c in fx.NAMES if c not in given}
    candidates = [c for c in ident if ident[c]["identifiable"]]
    steps, final = ranking.forward_select(d, m2, given, candidates, sigma2)
    named = [s for s in steps if s.name]
    missing = [s.name for s in named]
    steps_final = final
    boot = ranking.bootstrap(d, m2, given, candidates, sigma2, final, opt.bootstrap, seed=opt.seed)

    # single-effect gains on the base model (the first step's trial) for the ranking table
    first = {a[0]: a for a in steps[0].alternatives} if steps else {}
    ranking_rows = []
    for s in named:
        ranking_rows.append(_entry(s.name, final, score=max(0.0, min(1.0, s.gain / mse_base)),
                                   gain_rpm2=s.gain, z=s.z, named=True, inclusion=boot.get(s.name),
                                   identifiable=True))
    for c in candidates:
        if c in missing:
            continue
        try:
            pc = fx.fit(rows, m2, given + missing + [c], start=final)
        except Exception:
            continue
        g, z = ranking.gain_z(d, ranking.residuals(d, final), ranking.residuals(d, pc), sigma2)
        single = first.get(c)
        ranking_rows.append(_entry(c, pc, score=max(0.0, min(1.0, g / mse_base)), gain_rpm2=g, z=z, named=False,
                                   inclusion=boot.get(c), identifiable=True,
                                   physical=ranking._physical(c, getattr(pc, fx.LIBRARY[c].field)),
                                   alone_gain_rpm2=single[1] if single else None))
    for c in fx.NAMES:
        if c in given or c in candidates:
            continue
        ranking_rows.append({"effect": c, "score": 0.0, "params": {}, "named": False, "identifiable": False,
                             "inclusion": None, "se": ident[c]["se"], "meaning": fx.LIBRARY[c].meaning,
                             "plausibility": "not identifiable on these recordings",
                             "needs": fx.LIBRARY[c].excited_by})

    # confounding: alternatives that explained nearly as much at the step an effect was named
    confounded, separators = [], []
    for s in named:
        group = [s.name]
        for name, g, z, physical in s.alternatives:
            if name != s.name and physical and z >= ranking.Z_MIN and g >= ranking.CONFOUND_GAIN * s.gain:
                group.append(name)
        if len(group) > 1:
            confounded.append(group)
            for other in group[1:]:
                separators.append({"effects": [s.name, other], "recording": ranking.separator(s.name, other),
                                   "corr": ranking.partial_corr(d, base, s.name, other, given)})

    # A material constant as a test of confounding: an effect whose coefficient is a material
    # constant (schema: material, material_band; thermal_ra: copper's) named with a value far
    # from it means the effect it shares its work with (shares_work_with: magnet_thermal)
    # took part of it. If the material's value plus the other effect explains the held-out
    # rows as well, the data cannot tell the two apart, and the physical reading (copper +
    # magnets) is the one named.
    for name in list(missing):
        eff = fx.LIBRARY[name]
        other = eff.shares_work_with
        if (not other or other in given + missing
                or eff.is_material(getattr(final, eff.field))):
            continue
        oeff = fx.LIBRARY[other]
        try:
            alt = fx.fit(rows, m2, given + missing + [other])
        except Exception:
            alt = None
        if alt is not None:
            mse_sel = ranking.held_out_mse(d, ranking.residuals(d, final))
            mse_alt = ranking.held_out_mse(d, ranking.residuals(d, alt))
            b = getattr(alt, oeff.field)
            if oeff.plausibility(b)[0] and mse_alt <= mse_sel + MATERIAL_SLACK * sigma2:
                missing.append(other)
                final = alt
                for e in ranking_rows:
                    if e["named"]:
                        e.update(_entry(e["effect"], final, **{k: e[k] for k in e if k not in _ENTRY_KEYS}))
                ranking_rows = [e for e in ranking_rows if e["effect"] != other]
                # its share: what it removes once the material's coefficient is held
                held = fx.fit(rows, m2, given + missing[:-1], hold={name: eff.material})
                res_held = ranking.residuals(d, held)
                g, z = ranking.gain_z(d, res_held, ranking.residuals(d, alt), sigma2)
                ranking_rows.insert(len([e for e in ranking_rows if e["named"]]),
                                    _entry(other, final, score=max(0.0, min(1.0, g / mse_base)),
                                           gain_rpm2=g, z=z, named=True, inclusion=None, identifiable=True,
                                           note=f"named with {name} held at {eff.material_name}'s coefficient, "
                                                "which the free fit missed; not bootstrapped"))
                confounded.append([name, other])
                unit = eff.unit.replace("1/", "per_")
                separators.append({"effects": [name, other],
                                   "recording": ranking.separator(name, other),
                                   "corr": ranking.partial_corr(d, base, name, other, given),
                                   "material_check": {f"{name}_fitted_{unit}": getattr(steps_final, eff.field),
                                                      "held_out_mse_fitted": mse_sel,
                                                      f"held_out_mse_{eff.material_name}_plus_{oeff.material_name}":
                                                          mse_alt}})

    # residual analysis of the model under test and of the final model
    res_final = ranking.residuals(d, final)
    after_model = fx.identify(recs, m2, given + missing) if missing else model
    res_after = ranking.residuals(d, after_model)

    def analyse(res):
        parts = analysis.parts(rows, res)
        inputs = {}
        for key, arr in (("V", [r.v for r in rows]), ("I", [r.i for r in rows]), ("duty", [r.duty for r in rows]),
                         ("temp_C", [r.temp for r in rows]), ("speed", [r.ref for r in rows]),
                         ("dI/dt", [r.di_dt for r in rows])):
            pieces = analysis.parts(rows, res, arr)
            if pieces and all(np.all(np.isfinite(a)) for a in pieces):
                inputs[key] = pieces
        w = analysis.whiteness(parts)
        corr = analysis.correlates(parts, inputs)
        mse = ranking.held_out_mse(d, res)
        return {"mse": mse, "noise_var": sigma2, "excess": max(0.0, mse - sigma2), "whiteness": w,
                "correlates": corr}

    before_an = analyse(res_model)
    after_an = analyse(res_after)
    structured_left = (after_an["excess"] > 0.5 * sigma2) and not after_an["whiteness"]["white"]
    if not missing:
        if structured_left:
            verdict = ("No library effect explains the residual, but it is not noise: it is "
                       f"{after_an['excess'] / max(sigma2, 1e-12):.1f}x the noise variance above the noise floor "
                       "and not white. Its strongest correlates: " +
                       ", ".join(f"{c['input']} (r = {c['peak']:+.2f} at lag {c['peak_lag']})"
                                 for c in after_an["correlates"][:3] if c["significant"]) + ".")
        else:
            verdict = "Nothing missing: the residual is consistent with measurement noise."
    else:
        verdict = "Missing: " + ", ".join(f"{e['effect']} ({e['shown']})" for e in ranking_rows if e["named"]) + "."
        if confounded:
            verdict += " " + " ".join(
                f"{' and '.join(s['effects'])} cannot be told apart on these recordings; "
                f"a recording that would separate them: {s['recording']}." for s in separators)
        if structured_left:
            verdict += (" A structured residual remains that no library effect explains "
                        f"({after_an['excess'] / max(sigma2, 1e-12):.1f}x the noise variance); strongest correlates: " +
                        ", ".join(f"{c['input']} (r = {c['peak']:+.2f})" for c in after_an["correlates"][:3]
                                  if c["significant"]) + ".")
    unseen = [c for c in fx.NAMES if c not in given and not ident.get(c, {"identifiable": True})["identifiable"]]

    rmse_before = _rmse_by_condition(rows, res_model)
    rmse_after = _rmse_by_condition(rows, res_after)
    est_before = [r.ref - e for r, e in zip(rows, res_model)]
    est_after = [r.ref - e for r, e in zip(rows, res_after)]
    out = {
        "recordings": [{"name": r.name, "file": str(r.source), "rows": r.n, "train_rows": r.n_train,
                        "glitches_removed": len(r.removed), "has_temp": r.has_temp()} for r in recs],
        "warnings": [w for r in recs for w in r.warnings],
        "ra_ohm": ra, "ra_source": ra_source,
        "model_effects": given,
        "model": dataclasses.asdict(model),
        "missing_effects": missing,
        "confounded": confounded,
        "separating_recordings": separators,
        "not_identifiable": [{"effect": c, "needs": fx.LIBRARY[c].excited_by, "se": ident[c]["se"]} for c in unseen],
        "ranking": ranking_rows,
        "verdict": verdict,
        "noise_rpm": float(np.sqrt(sigma2)),
        "rmse_rpm": {"before": rmse_before, "after": rmse_after},
        "after_model": dataclasses.asdict(after_model),
        "residual_before": before_an,
        "residual_after": after_an,
        "steps": [{"effect": s.name or None, "gain_rpm2": s.gain, "z": s.z, "mse_before": s.mse_before,
                   "mse_after": s.mse_after,
                   "tried": [{"effect": a, "gain_rpm2": g, "z": z, "physical": bool(phy)}
                             for a, g, z, phy in s.alternatives]} for s in steps],
        "thresholds": {"z_min": ranking.Z_MIN, "rel_min": ranking.REL_MIN, "excess_min": ranking.EXCESS_MIN,
                       "confound_gain": ranking.CONFOUND_GAIN, "bootstrap": opt.bootstrap},
    }
    hyb = {}
    if opt.hybrid:
        try:
            hb = _hybrid(recs, model, opt.hybrid_iter, opt.seed)
        except TrainingError as exc:  # too few rows for a network: the physics verdict stands alone
            out["warnings"].append(f"hybrid before/after not computed: {exc}")
            opt = dataclasses.replace(opt, hybrid=False)
    if opt.hybrid:
        ha = _hybrid(recs, after_model, opt.hybrid_iter, opt.seed) if missing else hb
        out["rmse_rpm_hybrid"] = {"before": _rmse_by_condition(rows, [r.ref - h for r, h in zip(rows, hb)]),
                                  "after": _rmse_by_condition(rows, [r.ref - h for r, h in zip(rows, ha)]),
                                  "iterations": opt.hybrid_iter}
        hyb = {"before": hb, "after": ha}
    out["runtime_s"] = time.perf_counter() - t0
    plot = {"rows": rows, "est_before": est_before, "est_after": est_after, "hybrid": hyb,
            "res_before": res_model, "res_after": res_after}
    return out, plot
