"""hpddo compare from end to end: every training submitted at once, the observers built and tuned, the tables, the JSON files and the report."""
from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import json
import pathlib
import threading
import time
import numpy as np

from ... import progress
from ...logs import dataset, outdir
from ...model import identify
from ...model import physics as ph
from ...logs.errors import InputError
from .config import CompareConfig, FEATURE_SETS, TOOL, label, param_count
from .methods import _m2, _x_e, finish_fit, nn_features, reference, stack_rows
from .observers import observers_exe, tune_observers, write_mlp
from .tables import cv_folds, make_ood, make_table10, make_table8, make_table9, replay_m3, table7_chrono_and_validation, table7_loro
from .text import text_summary
from .training import Trainer
from . import ripple_peer


@dataclasses.dataclass
class Comparison:
    tables: dict
    out: pathlib.Path
    seconds: float


def run(log_paths, out_dir, cfg: CompareConfig, validation_paths=()) -> Comparison:
    """The whole comparison into out_dir (outdir policy: new, empty or a previous output of
    hpddo compare); raises the usual user errors before writing anything."""
    t0 = time.perf_counter()
    outdir.check(out_dir, TOOL)
    if len(log_paths) < 2:
        raise InputError("hpddo compare needs at least two labelled recordings (leave one recording out, "
                         "and the out-of-distribution test, train on some and test on the others)")
    recs = dataset.load_recordings(log_paths, dataset.TRAIN_FRACTION, cfg.glitch_filter)
    for r in recs:
        if not np.isfinite(reference(r)).any():
            raise InputError(f"{r.source}: no encoder readings (rpm_ref): hpddo compare needs labelled recordings")
    whole = dataset.load_recordings(log_paths, 0.0, cfg.glitch_filter)   # every row a test row
    vrecs = dataset.load_recordings(validation_paths, 0.0, cfg.glitch_filter) if validation_paths else []
    ropts = ripple_peer.check_options(cfg.ripples_per_rev, cfg.gear_ratio, recs + vrecs, cfg.ripple_floor_A,
                                      cfg.ripple_ke_vs_per_rad, cfg.ripple_prior_model)
    ra, _ = identify.ra_from_logs(recs, cfg.ra_ohm)
    m1 = ph.nameplate_params(ra)
    m2 = _m2(recs, ra)
    m2e = None
    if cfg.effects:
        from ...model import effects
        m2e = effects.identify(recs, m2, cfg.effects)
    say = progress.stage if cfg.progress else (lambda s: None)
    h, ep, seed = tuple(cfg.hidden), cfg.epochs, cfg.seed
    trainer = Trainer(cfg.workers, cfg.progress)
    try:
        with outdir.staged(pathlib.Path(out_dir), TOOL) as stage:
            work = stage / "work"
            # ---- every training, submitted at once (the longest first)
            x_tr, e_tr = _x_e(recs, m2)
            xn_tr, y_tr = stack_rows(recs, lambda r: (nn_features(r), reference(r)))
            jobs = []
            for hh in sorted(cfg.architectures, key=param_count, reverse=True):
                jobs.append((("M3", label(hh), "chronological"), x_tr, e_tr, hh, False))
            jobs.append((("pure NN", label(h), "chronological"), xn_tr, y_tr, h, True))
            for name, cols in FEATURE_SETS.items():
                if name != "full":
                    jobs.append((("M3", label(h), name), x_tr[:, list(cols)], e_tr, h, False))
            loro = {}
            for k, held in enumerate(recs):
                others = recs[:k] + recs[k + 1:]
                p = _m2(others, ra)
                xo, eo = _x_e(others, p)
                xno, yo = stack_rows(others, lambda r: (nn_features(r), reference(r)))
                loro[held.name] = (others, p, xo, eo)
                jobs.append((("M3", label(h), f"leave out {held.name}"), xo, eo, h, False))
                jobs.append((("pure NN", label(h), f"leave out {held.name}"), xno, yo, h, True))
            cv = cv_folds(recs, ra, seed)
            for k, fold in enumerate(cv["folds"]):
                jobs.append((("M3", label(h), f"CV fold {k + 1}"), fold["x"], fold["e"], h, False))
            ood = {}
            for r in recs:
                p = _m2([r], ra)
                xo, eo = _x_e([r], p)
                ood[r.name] = (p, xo, eo)
                jobs.append((("M3", label(h), f"trained on {r.name} only"), xo, eo, h, False))
            trainer.submit_all(jobs, ep, seed, first=[("M3", label(h), "chronological"),
                                                      ("pure NN", label(h), "chronological")])
            say(f"{len(jobs)} networks in {trainer.jobs} jobs on {cfg.workers} worker(s), {ep} epochs each; "
                "building and tuning the observers")

            # ---- three threads: the observers build and tune; the board observer is built
            # against the chronological M3 with and without the gate and replayed (the
            # networks train meanwhile in their processes)
            ripple = {} if ropts is not None else None  # {recording: ripple_peer.RippleSpeeds}, counted below

            def observers():
                jobs_ = {"chronological": (recs, m2)}
                jobs_.update({f"leave out {name}": (v[0], v[1]) for name, v in loro.items()})
                observers_exe()
                if ripple is not None:  # the counts first: the EKF that takes them is tuned with them
                    ripple.update(ripple_peer.speeds_of(recs + vrecs, ropts, ra, m2.ke_vs_per_rad,
                                                        cfg.ripple_ke_vs_per_rad, cfg.ripple_prior_model))
                    say("ripple counted")
                t = tune_observers(jobs_, work / "tuning", coarse=cfg.quick, ripple=ripple)
                say(f"observers tuned: EKF train RMSE {t['chronological']['train_rmse_rpm']['ekf']:.2f}, SMO "
                    f"{t['chronological']['train_rmse_rpm']['smo']:.2f} RPM (M2 "
                    f"{t['chronological']['train_rmse_rpm']['m2']:.2f})")
                return t

            chrono_fit = {}
            fit_lock = threading.Lock()

            def chrono():
                with fit_lock:
                    if not chrono_fit:
                        chrono_fit["fit"] = finish_fit(range(5), trainer.get(("M3", label(h), "chronological")),
                                                       x_tr, e_tr, gate=True)
                return chrono_fit["fit"]

            with cf.ThreadPoolExecutor(max_workers=3) as threads:
                fut_obs = threads.submit(observers)
                native = (True,) if cfg.quick else (True, False)
                fut_nat = {g: threads.submit(lambda g=g: replay_m3(recs, vrecs, m1, m2, chrono(), g, work, cfg))
                           for g in native}
                tuned_all = fut_obs.result()
                replays = {k: v for g in native for k, v in fut_nat[g].result().items()}
            fit = chrono()
            tuned = tuned_all.pop("chronological")
            tuned_loro = {k[len("leave out "):]: v for k, v in tuned_all.items()}
            say("native replays of M3 done")

            # ---- Table 7: chronological and never seen
            nn = trainer.get(("pure NN", label(h), "chronological"))
            mlp_file = write_mlp(nn[0], nn[1], (work / "pure_nn_chronological.mlp"))
            table7, native = table7_chrono_and_validation(recs, vrecs, m2, m2e, fit, replays, tuned, mlp_file, work,
                                                          ripple)
            table7["leave_one_out"] = table7_loro(whole, loro, tuned_loro, trainer, m1, m2e, cfg, work, ra, ripple)
            table7["tuned"] = {"chronological": tuned, "leave_one_out": tuned_loro}
            table7["checks"] = native
            if ripple is not None:
                table7["ripple_prior"] = ripple_peer.priors(ripple)

            # ---- Table 8, 9, 10, ood
            table8 = make_table8(recs, cv, trainer, fit, m2, cfg)
            table9 = make_table9(recs, trainer, m2, x_tr, e_tr, cfg)
            table10 = make_table10(recs, trainer, m2, x_tr, e_tr, cfg)
            tood = make_ood(recs, whole, ood, trainer, cfg)
            tables = {"table7": table7, "table8": table8, "table9": table9, "table10": table10, "ood": tood}
            for t in tables.values():
                t["command"] = cfg.command
                t["settings"] = settings(cfg, recs, vrecs)
            for name, t in tables.items():
                (stage / f"{name}.json").write_text(json.dumps(t, indent=1) + "\n")
            seconds = time.perf_counter() - t0
            from ...reports import compare as report
            report.write(tables, stage / "report", cfg.command, seconds)
            (stage / "summary.txt").write_text(text_summary(tables) + f"\nfinished in {seconds:.1f} s\n")
    finally:
        trainer.close()
    return Comparison(tables, pathlib.Path(out_dir), time.perf_counter() - t0)


def settings(cfg: CompareConfig, recs, vrecs) -> dict:
    return {"hidden": list(cfg.hidden), "epochs": cfg.epochs, "seed": cfg.seed, "quick": cfg.quick,
            "effects": list(cfg.effects),
            "ripple": ({"ripples_per_rev": cfg.ripples_per_rev, "gear_ratio": cfg.gear_ratio,
                        "ke_vs_per_rad": cfg.ripple_ke_vs_per_rad,
                        "prior_model": None if cfg.ripple_prior_model is None else cfg.ripple_prior_model.to_json()}
                       if cfg.ripples_per_rev is not None else None),
            "recordings": [r.source.name for r in recs],
            "validation": [r.source.name for r in vrecs], "train_fraction": dataset.TRAIN_FRACTION,
            "training": "network.train's algorithm (Adam 1e-3, batch 200, L2 1e-4, Glorot, no early stop), "
                        "in lockstep with BLAS products (network.train_lockstep)"}
