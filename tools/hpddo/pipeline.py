"""The offline pipeline: bench logs -> M1, M2 (+ effects), M3 -> model header, golden
vectors, native replay metrics. All outputs appear in the output folder together at
the end, or not at all."""
from __future__ import annotations

import dataclasses
import hashlib
import pathlib

import numpy as np

from . import progress, schema
from .evaluation import baseline
from .evaluation.evaluate import recordings_record, replay_natively, score_recordings
from .logs import benchlog, dataset, outdir
from .model import export, identify
from .evaluation import metrics as metrics_mod
from .model import physics as ph
from .logs.errors import InputError
from .model.observer_ref import Limits, ModelData
from .model.train import TrainConfig, Residual, residual_or_physics_only, training_rows

GOLDEN_ROWS_PER_RECORDING = 24
# M1's nameplate when the user gives none (hpddo train --rated-v, --rated-rpm)
DEFAULT_RATED_V = 12.0
DEFAULT_RATED_RPM = 1000.0


@dataclasses.dataclass
class PipelineConfig:
    name: str = "default"
    ra_ohm: float | None = None
    rated_V: float = DEFAULT_RATED_V
    rated_rpm: float = DEFAULT_RATED_RPM
    # where the nameplate came from: "default" (none given: DEFAULT_RATED_V/RPM), "given"
    # (both given) or "partly given" (one of them)
    nameplate_source: str = "default"
    ke_fit: str = "eq20"
    effects: tuple = ()
    hold: dict = dataclasses.field(default_factory=dict)  # {effect: coefficient} held, not fitted (--hold)
    # the dynamic family (inertia, viscous and Coulomb friction; schema.DYNAMICS): identified from the
    # training rows of recordings at 50 Hz and up and computed by the model (hpddo train --dynamics)
    dynamics: bool = False
    # M2 already identified on these recordings (Ke and the effect coefficients, e.g. a
    # diagnosis's after_model): used as it is instead of identifying it again
    physics: ph.PhysicsParams | None = None
    train: TrainConfig = dataclasses.field(default_factory=TrainConfig)
    train_fraction: float = dataset.TRAIN_FRACTION
    glitch_filter: bool = True
    leave_one_out: bool = False  # also train on all recordings but one and score it, for each
    # the speed taken as rpm_ref (hpddo.ripple.reference.Ripple); None: the encoder, the log's column
    reference: object | None = None
    command: str = "tools/gen_weights.py"
    report: bool = False  # also write report/index.html (estimate against encoder, the RMSE table)


@dataclasses.dataclass
class PipelineResult:
    recordings: list
    m1: ph.PhysicsParams
    m2: ph.PhysicsParams
    residual: Residual
    model: ModelData
    metrics: dict
    table: str
    out: pathlib.Path


def nameplate_record(cfg: PipelineConfig) -> dict:
    """metrics.json identification.nameplate: M1's rated voltage and speed, where they came
    from, and a note for the user where they were not given."""
    rec = {"rated_V": cfg.rated_V, "rated_rpm": cfg.rated_rpm, "source": cfg.nameplate_source}
    if cfg.nameplate_source != "given":
        rec["note"] = (f"M1 uses the default nameplate {cfg.rated_V:g} V, {cfg.rated_rpm:g} RPM; give --rated-v "
                       "and --rated-rpm for your motor" if cfg.nameplate_source == "default" else
                       f"M1 uses the nameplate {cfg.rated_V:g} V, {cfg.rated_rpm:g} RPM, partly the default; "
                       "give both --rated-v and --rated-rpm for your motor")
    return rec


def data_hash(paths) -> str:
    h = hashlib.sha256()
    for p in sorted(paths, key=lambda q: pathlib.Path(q).name):
        h.update(pathlib.Path(p).name.encode() + b"\0" + pathlib.Path(p).read_bytes())
    return h.hexdigest()


def limits_of(recs) -> Limits:
    """The readings the model's observer accepts: the board's (schema.Limits), the channels' full scale the
    widest any training recording declares (dataset.full_scale: a bench's own divider or shunt, whose board
    reads as far)."""
    if not recs:
        return Limits()
    scales = [dataset.full_scale(r.meta, r.source) for r in recs]
    return dataclasses.replace(Limits(), v_max_V=max(s["v_V"] for s in scales),
                               i_max_A=max(s["i_A"] for s in scales))


def model_data(m1, m2, res: Residual, dynamics: dict | None = None, recs=()) -> ModelData:
    layers = [(w.T.astype(np.float32), b.astype(np.float32)) for w, b in zip(res.mlp.coefs_, res.mlp.intercepts_)]
    return ModelData(physics=m2, dynamics=dynamics, scaler_mean=res.scaler.mean_.astype(np.float32),
                     scaler_scale=res.scaler.scale_.astype(np.float32), layers=layers,
                     env_lo=res.env_lo.astype(np.float32), env_hi=res.env_hi.astype(np.float32),
                     gate=res.gate, clamp_rpm=float(np.float32(res.clamp_rpm)), limits=limits_of(recs), nameplate=m1)


def golden_samples(recs):
    """A stream of test rows from each recording, and faults the boards must survive."""
    out = []
    for r in recs:
        test = r.part("test").iloc[:GOLDEN_ROWS_PER_RECORDING]
        t = test["t_s"].to_numpy(float)
        dt = np.diff(np.concatenate([[t[0] - (t[1] - t[0])], t]))
        temp = test["temp_C"].to_numpy(float) if "temp_C" in test else np.full(len(test), np.nan)
        seq0 = len(out) + 1000 * (len(out) // GOLDEN_ROWS_PER_RECORDING + 1)  # a gap between recordings
        for k, (v, i) in enumerate(zip(test["v_V"], test["i_A"])):
            out.append((float(v), float(i), None if np.isnan(temp[k]) else float(temp[k]), float(dt[k]), seq0 + k))
    v, i, t, dt, seq = out[-1]
    out += [(float("nan"), i, t, dt, seq + 1), (v, float("inf"), t, dt, seq + 2), (v, i, t, dt, seq + 3),
            (v * 3.0, i * 4.0, t, dt, seq + 4), (v, i, None, dt, seq + 5)]
    return out


def check_physical(recs, m2: ph.PhysicsParams, names) -> None:
    """An InputError where a named effect's fitted coefficient lies outside what that effect can
    physically be (schema.Effect.physical, the plausible range widened twice): the recordings
    do not determine it, or the error is another effect's (e.g. an inductance fitted negative
    on a 100 Hz log). A model carrying it would put a false value on the board."""
    from .model import effects
    for name in names:
        e = effects.LIBRARY[name]
        value = float(getattr(m2, e.field))
        if not e.is_physical(value):
            lo, hi = e.physical
            files = ", ".join(str(r.source) for r in recs)
            raise InputError(f"{files}: --effects {name}: fitted {e.show(value)}, outside its physical range "
                             f"{lo * e.show_scale:.3g}..{hi * e.show_scale:.3g} {e.show_unit} ({e.coefficient}): these "
                             f"recordings do not determine it, or another effect shows through it; leave it out, or "
                             f"add what would show it: {e.excited_by} (hpddo diagnose names what the data support)")


def identify_dynamics(recs, m2: ph.PhysicsParams):
    """The dynamic family of hpddo train --dynamics: J, B, Tc from the training rows of the
    recordings at 50 Hz and up (model/dynamics.py, with their intervals) and the observer's
    tau chosen on the training rows with M2's speed as its measurement. Returns (the
    identification, dynamics_ref.dynamics_params); an InputError naming the file(s) where the
    recordings do not determine J, B or Tc."""
    from .model import dynamics as family
    from .model import dynamics_ref
    from .model.train import physics_rpm
    fam = family.identify(recs, m2.ra_ohm, m2.ke_vs_per_rad, [physics_rpm(r, m2) for r in recs],
                          la_given_H=m2.la_H)
    if not fam.fast:
        slow = ", ".join(str(r.source) for r in recs)
        raise InputError(f"{slow}: --dynamics needs a recording at {family.MIN_RATE_HZ:g} Hz or faster (the fastest "
                         f"here is at {fam.rate_hz:.3g} Hz, where a row averages over the motor's transients); "
                         f"what would determine J, B and Tc: {family.NEEDS}")
    fast = ", ".join(str(r.source) for r in recs if r.name in fam.fast)
    for q in fam.quantities:
        if q.field != "la_H" and not q.determined:
            raise InputError(f"{fast}: --dynamics: {q.quantity} not determined by these recordings ({q.why}); "
                             f"what would determine it: {q.needs}")
    values = {q.field: q.value for q in fam.quantities if q.field != "la_H"}
    return fam, dynamics_ref.dynamics_params(**values, tau_obs_s=fam.tau_obs_s)


def dynamics_record(fam, dyn: dict) -> dict:
    """metrics.json identification.dynamics: the family in the model (SI, float32 as exported),
    each identified quantity with its 95 % interval, and what it came from."""
    return {"model": {k: float(v) for k, v in dyn.items()},
            "quantities": [q.to_json() for q in fam.quantities],
            "rate_hz": fam.rate_hz, "fast_recordings": fam.fast, "speed_from": fam.speed_from,
            "steps": fam.steps, "segments": fam.segments, "lag_s": fam.lag_s,
            "tau_obs_s": fam.tau_obs_s, "text": fam.text()}


def run(log_paths, out_dir, cfg: PipelineConfig) -> PipelineResult:
    """Runs everything; raises BenchLogError / IdentificationError / ValueError on bad input
    before anything is written to out_dir."""
    outdir.check(out_dir, "gen_weights")  # before the work: a refused folder costs nothing
    if cfg.leave_one_out:
        _check_leave_one_out(log_paths)  # before the work
    stray = [n for n in cfg.hold if n not in cfg.effects]
    if stray:  # before the work: a hold without its effect would be dropped without a word
        raise InputError(f"--hold {', '.join(stray)}: not among --effects ({', '.join(cfg.effects) or 'none'}); "
                         "add it there")
    recs = dataset.load_recordings(log_paths, cfg.train_fraction, cfg.glitch_filter, cfg.reference)
    progress.stage("identifying M1 and M2" + (f" with {', '.join(cfg.effects)}" if cfg.effects else ""))
    ra, ra_source = identify.ra_from_logs(recs, cfg.ra_ohm)
    m1 = ph.nameplate_params(ra, cfg.rated_V, cfg.rated_rpm)
    if cfg.physics is not None:
        m2 = cfg.physics
    else:
        m2 = identify.m2_params(recs, ra, cfg.ke_fit)
        if cfg.effects:
            from .model import effects
            m2 = effects.identify(recs, m2, cfg.effects, cfg.hold)
            check_physical(recs, m2, cfg.effects)
    if cfg.dynamics:
        progress.stage("identifying the dynamic family (J, B, Tc)")
    fam, dyn = identify_dynamics(recs, m2) if cfg.dynamics else (None, None)
    progress.stage(f"training M3 {cfg.train.hidden}, {cfg.train.max_iter} epochs")
    res = residual_or_physics_only(recs, m2, cfg.train, dyn)  # physics only below one batch of rows
    model = model_data(m1, m2, res, dyn, recs)

    out = pathlib.Path(out_dir)
    with outdir.staged(out, "gen_weights") as stage:
        prov = {"command": cfg.command, "seed": cfg.train.seed,
                "data": ", ".join(sorted(pathlib.Path(p).name for p in log_paths)),
                "data_sha256": data_hash(log_paths),
                "ra_ohm": f"{ra:.6g} ({ra_source})", "ke_fit": cfg.ke_fit,
                "effects": ",".join(m2.effect_names()) or "none",
                "training": (f"Adam lr={cfg.train.learning_rate:g} batch={cfg.train.batch_size} "
                             f"iterations={cfg.train.max_iter}, {res.n_train} rows, chronological "
                             f"{cfg.train_fraction:.0%} of each recording") if res.trained else
                            f"none: the residual network is {res.note}"}
        if dyn is not None:
            prov["dynamics"] = ", ".join(f"{d.field} {float(dyn[d.field]):.6g} {d.unit}" for d in schema.DYNAMICS)
        name = cfg.name
        progress.stage("exporting the model headers and golden vectors (float, fixed point, int8)")
        (stage / f"model_{name}.h").write_text(export.model_header(model, name, prov))
        samples = golden_samples(recs)
        rows = export.golden_rows(model, samples)
        (stage / f"golden_{name}.h").write_text(export.golden_header(rows, name, prov))
        (stage / f"golden_{name}.csv").write_text(export.golden_csv(rows))
        export.write_fixed_point(stage, model, name, prov, samples)  # model_<name>_q.h, its goldens
        # model_<name>_q8.h, its goldens: the int8 network, rounded for the training rows
        export.write_int8(stage, model, name, prov, samples, training_rows(recs, m2)[0] if res.trained else None)
        work = stage / "work"  # cleaned logs, the replay built for this model, its estimates
        est = replay_natively(recs, stage, name, work)
        progress.stage("scoring the estimates")
        lookup = baseline.Lookup.fit(recs)
        (stage / baseline.FILE).write_text(lookup.to_json())
        metrics = score_recordings(recs, est, export.model_checksum(model), lookup)
        table = metrics_mod.table(metrics)
        metrics["identification"] = {
            "ra_ohm": ra, "ra_source": ra_source, "ke_m1_vs_per_rad": m1.ke_vs_per_rad,
            "ke_m2_vs_per_rad": m2.ke_vs_per_rad, "ke_fit": cfg.ke_fit, "t_ref_C": m2.t_ref_C,
            "effects": {e: getattr(m2, ph.EFFECT_BITS[e][1]) for e in m2.effect_names()},
            **({"held": dict(cfg.hold)} if cfg.hold else {}),  # --hold (absent without: the same bytes as before)
            "clamp_rpm": model.clamp_rpm, "hidden": list(cfg.train.hidden), "train_rows": res.n_train,
            "final_loss": res.loss_curve[-1] if res.loss_curve else None,
            "nameplate": nameplate_record(cfg),
        }
        if dyn is not None:
            metrics["identification"]["dynamics"] = dynamics_record(fam, dyn)
        if not res.trained:
            metrics["identification"]["residual"] = res.note
        metrics.update(recordings_record(recs))
        if cfg.leave_one_out:
            metrics["leave_one_out"] = leave_one_out(
                log_paths, stage / "leave_one_out",
                dataclasses.replace(cfg, leave_one_out=False, report=False, train=dataclasses.replace(cfg.train, progress=False)))
        (stage / "metrics.json").write_text(benchlog.json_text(metrics, indent=2))
        (work / "loss_curve.json").write_text(benchlog.json_text(res.loss_curve))
        if cfg.report:
            from .reports import training as report
            progress.stage("writing the report")
            report.write(metrics, work / "estimates", stage / "report", f"hpddo train: {out}",
                         [f"Model header: {out / f'model_{name}.h'}. Effects in the physics model: "
                          f"{', '.join(m2.effect_names()) or 'none'}. RMSE of the held-out "
                          f"{1 - cfg.train_fraction:.0%} of each recording (chronological split), measured by "
                          "the native replay through the board observer (hpddo_core); lookup: the mean "
                          "training speed of the nearest training operating point."])
    return PipelineResult(recs, m1, m2, res, model, metrics, table, out)


def _check_leave_one_out(log_paths) -> None:
    if len(log_paths) < 2:
        raise InputError("leave-one-out needs at least two recordings (one to leave out, one to train on)")


def leave_one_out(log_paths, out_dir, cfg: PipelineConfig) -> dict:
    """Cross-recording validation: for each recording, the pipeline on all the others into
    out_dir/<stem>/model, and that model scored on every row of the one left out
    (hpddo.evaluation.evaluate) into out_dir/<stem>/evaluation. Returns {recording: rmse_rpm of its
    rows (M1, M2, M3, lookup)} plus "average" per model: the figure to trust for a new
    run, as no row of a scored recording was seen in training."""
    from .evaluation.evaluate import evaluate

    paths = [pathlib.Path(p) for p in log_paths]
    _check_leave_one_out(paths)
    out = pathlib.Path(out_dir)
    if cfg.reference is not None and hasattr(cfg.reference, "over"):  # the ripple counted once over every recording
        cfg = dataclasses.replace(cfg, reference=cfg.reference.over(paths))
    scores, why = {}, {}
    for k, held in enumerate(paths):
        others = paths[:k] + paths[k + 1:]
        stem = held.stem
        progress.stage(f"leave one out {k + 1}/{len(paths)}: trained without {held.name}, scored on it")
        try:
            res = run(others, out / stem / "model",
                      dataclasses.replace(cfg, command=f"{cfg.command} (leave out {held.name})"))
        except InputError as exc:  # the others alone cannot be fitted (the model on every recording could be)
            name = benchlog.read_log(held).condition
            scores[name], why[name] = None, f"the others alone cannot be fitted: {exc}"
            continue
        ev = evaluate(res.out, [held], out / stem / "evaluation", glitch_filter=cfg.glitch_filter,
                      reference=cfg.reference)
        name = ev.recordings[0].name
        scores[name] = {m: v[name] for m, v in ev.metrics["rmse_rpm"].items()}
    models = list(next((s for s in scores.values() if s is not None), metrics_mod.MODELS))  # (none scored: all)
    scores = {c: s if s is not None else {m: None for m in models} for c, s in scores.items()}
    avg = {m: metrics_mod.figure(sum(s[m] for s in scores.values()) / len(scores))
           if all(s[m] is not None for s in scores.values()) else None for m in models}
    return {"recordings": scores, "average": avg, "not_scored": why}



def leave_one_out_table(loo: dict) -> str:
    """The leave-one-out scores as text: one line per recording left out, then the average."""
    models = list(loo["average"])
    num = metrics_mod.table_cell
    lines = ["RMSE on every row of each recording, trained on the others (leave one out, RPM)",
             f"{'left out':<10s} " + " ".join(f"{m:>10s}" for m in models)]
    lines += [f"{c:<10s} " + " ".join(num(s[m]) for m in models) for c, s in loo["recordings"].items()]
    lines.append(f"{'average':<10s} " + " ".join(num(loo['average'][m]) for m in models))
    lines += [f"({c}: not scored: {w})" for c, w in loo.get("not_scored", {}).items()]
    return "\n".join(lines) + "\n"
