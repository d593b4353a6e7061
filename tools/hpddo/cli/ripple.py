"""Speed from the commutation ripple: per window of each bench log, the output-shaft speed
counted from the current bursts beside it (<condition>.ripple.csv, docs/bench-log.md), with a
confidence and the reason where there is none (docs/ripple.md).

    hpddo ripple LOG... --ripples-per-rev N --gear-ratio G --out OUT [--ke-vs-per-rad KE | --model DIR]
    hpddo ripple CAPTURE.ripple.csv --ripples-per-rev N --gear-ratio G --out OUT [--rpm-range LO HI]
    hpddo ripple LOG... --calibrate --gear-ratio G --out OUT [--ripples-per-rev N]
    hpddo ripple LOG... --coast --ripples-per-rev N --gear-ratio G --out OUT (--ke-vs-per-rad KE | --model DIR)
                        [--brush-drop-v V] [--ra-ref OHM C]

--calibrate finds the ripples per motor revolution from the data (the comb of rotation lines each
window shows, and the strongest line against the encoder or tachometer where the log has rpm_ref),
says it against the N given, and writes OUT/summary.json; it counts no speed.

(--prior-model DIR, --prior-name NAME: the same as --model, --name, as hpddo train, diagnose and evaluate
spell them with --reference ripple)

The back-EMF prior that picks the main line among its sub-harmonics is M2, (V - I Ra) / Ke:
with --ke-vs-per-rad, that Ke; with --model, the identified M2 of a model folder written by
hpddo train, with the named effects it was trained with (its own Ra and Ke); without either,
a Ke calibrated from the ripple itself (the windows the comb alone resolves). Where a log has encoder speeds (rpm_ref), the ripple speed is
scored against them (rows the pipeline's glitch filter marks left out) and the gear ratio checked: the statement says when the data's ratio is
not the one given. Without Ra (no --ra-ohm, no ra_ohm metadata) there is no back-EMF prior: --rpm-range
LO HI (the output shaft's speeds the user knows it turns at) is the prior, or none (the comb alone);
with --rpm-range a confident count outside it is not confident. A range checks the ripples per revolution
given only where it is no more than 5 % wide: a wider one holds a count under another figure too, and the
recording's rotation combs must confirm the figure.

A burst file given alone (CAPTURE.ripple.csv, e.g. written by hpddo import from a scope's CSV, a sound
card's WAV or a MATLAB .mat; docs/ripple-captures.md) is a current-only capture: no voltage, duty or
encoder; its bursts are counted with the speed range as the prior, or none.
Writes OUT/<condition>.ripple_speed.csv and OUT/summary.json.

--coast reads the coast probes beside each log (<condition>.coast.csv: the drive held off for a few
milliseconds, the current and the terminal voltage sampled in turn; docs/ripple-coast.md) and gives
at each probe Ke (the back-EMF over the ripple's speed), Ra (from the driven spans around it) and
the winding's temperature (copper's coefficient, from --ra-ref OHM C, a multimeter's Ra at a known
temperature, else the first probe's Ra at the log's first temperature reading; given only where its 99 %
interval lies within 3 K, --winding-tolerance-k): OUT/<condition>.coast_probes.csv and OUT/summary.json; it
counts no other window. --brush-drop-v: the brushes' drop while current flows, where known (without it Ra
carries drop / I).
"""
from __future__ import annotations

import argparse
import math
import sys

from . import options

TOOL = "ripple"


def parser(prog: str = "hpddo ripple") -> argparse.ArgumentParser:
    from ..ripple.options import FIGURE_CHECK_REL

    p = options.new_parser(prog, __doc__)
    options.logs(p, help="bench logs (CSV, docs/bench-log.md), each with its <condition>.ripple.csv beside it")
    # the prior model as --model (this command scores no model of its own), --prior-model as the others spell it
    options.ripple(p, required=True, prior_flags=("--model", "--name") + options.PRIOR_MODEL_FLAGS,
                   n_optional="not needed with --calibrate")
    p.add_argument("--calibrate", action="store_true",
                   help="find the ripples per motor revolution from the data (and the encoder where there is one); "
                        "no speed is counted")
    p.add_argument("--coast", action="store_true",
                   help="Ke, Ra and the winding's temperature at the coast probes of each log (<condition>.coast.csv "
                        "beside it); no other window is counted")
    p.add_argument("--brush-drop-v", type=options.non_negative_float, default=None, metavar="V",
                   help="--coast: the brushes' contact drop while current flows, V (default: none declared)")
    p.add_argument("--ra-ref", type=float, nargs=2, default=None, metavar=("OHM", "C"),
                   help="--coast: the winding's Ra at a known temperature (a multimeter's), the temperature's "
                        "reference (default: the first probe's Ra at the log's first temperature reading)")
    p.add_argument("--winding-tolerance-k", type=options.positive_float, default=None, metavar="K",
                   help="--coast: a winding temperature is given only where its 99 %% interval lies within this "
                        "(default 3 K)")
    options.ra_ohm(p)
    p.add_argument("--rpm-range", type=options.non_negative_float, nargs=2, metavar=("LO", "HI"), default=None,
                   help="the output shaft's speed range (RPM): the prior where there is no back-EMF one (no Ra, a "
                        "current-only capture); a confident count outside it is not confident, and it checks the "
                        f"ripples per revolution given only where it is no more than {FIGURE_CHECK_REL * 100:g} %% wide "
                        "(else the recording's rotation combs must confirm the figure)")
    options.out(p, "output folder: new, empty, or a previous output of hpddo ripple")
    options.quiet(p)
    return p


def run(args) -> int:
    import dataclasses

    import numpy as np

    from .. import progress
    from ..logs import benchlog, dataset, outdir
    from ..logs import ripple as rf
    from ..logs.errors import InputError
    from ..ripple import reference
    from ..ripple.encoder import check_ratio, span_reference
    from ..ripple.log import ra_of, speed_of_bench
    from ..ripple.line import CALIBRATE_AGREE, CALIBRATE_MIN_WINDOWS, figure_confirmed, other_figure
    from ..ripple.options import Options

    if args.ripples_per_rev is None and not args.calibrate:
        raise InputError("--ripples-per-rev N is required (or --calibrate, which finds it from the data)")
    opts = Options(args.ripples_per_rev or 0, args.gear_ratio)
    if args.calibrate:
        return _calibrate(args, opts)
    if (args.brush_drop_v is not None or args.ra_ref is not None or args.winding_tolerance_k is not None) \
            and not args.coast:
        raise InputError("--brush-drop-v, --ra-ref and --winding-tolerance-k apply with --coast")
    if args.coast:
        return _coast(args, opts)
    if args.floor_a is not None:
        opts = dataclasses.replace(opts, floor_A=args.floor_a)
    if args.prior_model is not None and args.ra_ohm is not None:  # refused before any work
        raise InputError("--ra-ohm does not apply with --model: the model's M2 has its own Ra")
    if args.rpm_range is not None and not args.rpm_range[0] < args.rpm_range[1]:
        raise InputError(f"--rpm-range {args.rpm_range[0]:g} {args.rpm_range[1]:g}: LO must be under HI")
    model = options.prior_model_of(args)  # a bad folder refused before any log is read
    summary = {}
    logs = [p for p in args.logs if not p.name.endswith(rf.SUFFIX)]  # the others: current-only captures
    read = {}
    for k, path in enumerate(logs):
        progress.stage(f"{path}: reading the log ({k + 1}/{len(logs)})")
        read[path] = benchlog.read_log(path)
    _one_name_each({path: read[path].condition for path in logs})
    # the logs are recordings of one motor: the ripples per revolution given is checked over all of them
    if logs:  # (captures alone: each counted below, with its own stage line)
        progress.stage(f"counting the ripple of {len(logs)} logs' bursts" if len(logs) > 1
                       else f"counting the ripple of {logs[0]}'s bursts")
    counted = dict(zip(logs, speed_of_bench([(p, read[p].df, read[p].meta, None) for p in logs], opts,
                                            args.ra_ohm, args.ke_vs_per_rad, model=model, rpm_range=args.rpm_range)))
    with outdir.staged(args.out, TOOL) as stage:
        for k, path in enumerate(args.logs):
            if path.name.endswith(rf.SUFFIX):  # a current-only capture, no bench log
                progress.stage(f"{path}: reading the capture, counting its ripple ({k + 1}/{len(args.logs)})")
                name, s_cap = _capture(path, opts, args, stage)
                if name in summary:  # (the output refused whole: staged)
                    raise InputError(f"{path}: its condition {name!r} is another input's too; each writes "
                                     f"OUT/<condition>.ripple_speed.csv: give each recording its own # condition=")
                summary[name] = s_cap
                continue
            log = read[path]
            df = log.df
            est, ke, ke_from = counted[path]
            rows = est["row"].to_numpy()
            est.insert(1, "t_s", df["t_s"].to_numpy()[rows])
            # the count is a speed; its direction is the back-EMF's (a reversed shaft's speed negative, as its
            # encoder reads it)
            est["rpm"] = est["rpm"].to_numpy(float) * reference.direction(df.iloc[rows],
                                                                         ra_of(log.meta, args.ra_ohm)) + 0.0
            name = log.condition
            est[list(COLUMNS)].rename(columns={"rpm": "rpm_ripple"}).to_csv(stage / f"{name}.ripple_speed.csv", index=False,
                                                                    float_format="%.6g")
            conf = est["confident"].to_numpy()
            above = np.abs(est["i_mean_A"].to_numpy()) >= opts.floor_A  # (either direction, as the count's floor)
            s = {"windows": len(est), "confident": int(conf.sum()), "above_floor": int(above.sum()),
                 "stalls": int(est["stall"].sum()),
                 "ke_prior_vs_per_rad": ke if math.isfinite(ke) else None, "ke_from": ke_from,
                 "prior_model": None if model is None else model.to_json(),
                 "reasons": {k or "confident": int(n) for k, n in est["key"].value_counts().sort_index().items()},
                 "commutator": _commutator(est)}
            if "rpm_ref" in df and np.isfinite(df["rpm_ref"].to_numpy()[rows]).any():
                glitch, _ = dataset.glitch_mask(df)  # the glitch filter of the pipeline (docs/pipeline.md)
                ref = np.where(glitch, np.nan, df["rpm_ref"].to_numpy())[rows]
                s["glitch_rows_left_out"] = int(glitch.sum())
                # a span's count against the encoder over the same span (ripple.span_reference)
                ref_span = span_reference(est, ref)
                ok = conf & np.isfinite(ref_span) & (ref_span != 0)
                if ok.any():
                    e = est["rpm"].to_numpy()[ok] / ref_span[ok] - 1
                    s["rms_vs_encoder_pct"] = float(100 * np.sqrt(np.mean(e ** 2)))
                    s["max_vs_encoder_pct"] = float(100 * np.max(np.abs(e)))
                window_s = float(np.median(np.diff(df["t_s"].to_numpy()))) if len(df) > 1 else math.nan
                # one encoder count per window where the header declares the encoder (docs/bench-log.md),
                # else check_ratio reads it from the readings
                sensors = dataset.sensor_meta(log.meta, path)
                s["ratio_check"] = check_ratio(est, ref, window_s, opts,
                                                  encoder_step_rpm=dataset.encoder_count_rpm(sensors, window_s))
            summary[name] = s
            share = f"{(conf & above).sum() / above.sum():.1%}" if above.sum() else "-"
            line = (f"{name}: {len(est)} windows, confident {conf.sum()} ({share} of the {above.sum()} above "
                    f"{opts.floor_A:g} A)" + (f", a stall (0 RPM within its bound) on {s['stalls']}"
                                              if s["stalls"] else "") + (f"; prior Ke {ke:.4f} V s/rad from {s['ke_from']}" if math.isfinite(ke)
                                                 else f"; no back-EMF prior ({s['ke_from']})"))
            if "rms_vs_encoder_pct" in s:
                line += f"; against the encoder RMS {s['rms_vs_encoder_pct']:.3f} %, max {s['max_vs_encoder_pct']:.2f} %"
            print(line)
            print(f"{name}: {s['commutator']['statement']}")
            other = other_figure(est, opts)  # over the comb windows, the damaged ones left out
            if other is not None:
                m, k, n_other, n_shown = other
                if figure_confirmed(k, n_shown):  # as --calibrate would name it
                    print(f"{name}: the ripple is {m} per revolution, not the {opts.ripples_per_rev} given, in "
                          f"{k} of the {n_shown} windows whose lines form a rotation comb "
                          f"({int((est['key'] == 'multiple').sum())} windows not confident for it); hpddo ripple "
                          "--calibrate finds it")
                else:  # a few combs at other numbers (a narrow spacing takes lines by chance) name no figure
                    print(f"{name}: {n_other} of the {n_shown} windows whose lines form a rotation comb show "
                          f"another number than the {opts.ripples_per_rev} given ({m} the commonest, in {k}); too few "
                          f"agree on one to name the motor's ({CALIBRATE_MIN_WINDOWS} windows and "
                          f"{CALIBRATE_AGREE:.0%} of the comb windows needed, as hpddo ripple --calibrate needs)")
            if "ratio_check" in s:
                print(f"{name}: {s['ratio_check']['statement']}")
            if not args.quiet:
                print(_no_estimate(est, s["reasons"]), file=sys.stderr)
        benchlog.write_text_atomic(stage / "summary.json", benchlog.json_text(summary, indent=1, sort_keys=True,
                                                                                 default=float))
    return 0


COLUMNS = ("seq", "t_s", "rpm", "confidence", "confident", "reason", "f_Hz", "cycles", "i_mean_A", "rpm_prior",
           "rpm_fft", "stall", "rpm_bound", "rot_hz", "multiple", "rot1_rel", "rot2_rel",
           "fault_rel")  # OUT/<condition>.ripple_speed.csv, rpm written rpm_ripple


COAST_COLUMNS = ("t_s", "row", "e_V", "e_sd_V", "rpm_cut", "rpm_sd", "ke_vs_per_rad", "ke_sd", "ra_ohm", "ra_sd_ohm",
                 "winding_C", "winding_sd_K", "reason")  # OUT/<condition>.coast_probes.csv


def _coast(args, opts) -> int:
    """--coast: the coast probe estimator (hpddo.ripple.coast) on each log, its bursts and its probes."""
    import dataclasses

    import numpy as np

    from .. import progress
    from ..logs import benchlog, outdir
    from ..logs import coast as coast_file
    from ..logs import ripple as rf
    from ..logs.errors import InputError
    from ..ripple import coast as rc
    from ..ripple.options import CoastOptions

    if args.prior_model is not None and (args.ra_ohm is not None or args.ke_vs_per_rad):
        raise InputError("--ra-ohm and --ke-vs-per-rad do not apply with --model: the model's M2 has its own")
    model = options.prior_model_of(args)
    if model is None and not args.ke_vs_per_rad:
        raise InputError("--coast needs the nominal Ke that places the ripple's line: --ke-vs-per-rad KE or "
                         "--model DIR (a model of hpddo train)")
    if args.ra_ref is not None and not (args.ra_ref[0] > 0 and np.isfinite(args.ra_ref).all()
                                        and args.ra_ref[1] > ABSOLUTE_ZERO_C):
        raise InputError(f"--ra-ref {args.ra_ref[0]:g} {args.ra_ref[1]:g}: Ra must be > 0 and the temperature above "
                         f"absolute zero ({ABSOLUTE_ZERO_C:g} C), both finite")
    captures = [p for p in args.logs if p.name.endswith(rf.SUFFIX)]
    if captures:  # (read as a bench log, a burst file was refused for its missing columns)
        raise InputError(f"{captures[0]}: a current-only capture has no coast probes: --coast reads a bench log with "
                         "its <condition>.ripple.csv and <condition>.coast.csv beside it (docs/ripple-coast.md)")
    copts = CoastOptions(brush_drop_V=args.brush_drop_v or 0.0)
    if args.winding_tolerance_k is not None:
        copts = dataclasses.replace(copts, winding_tolerance_K=float(args.winding_tolerance_k))
    if args.ra_ref is not None:
        copts = dataclasses.replace(copts, ra_ref_ohm=float(args.ra_ref[0]), ra_ref_C=float(args.ra_ref[1]))
    summary = {}
    with outdir.staged(args.out, TOOL) as stage:
        for k, path in enumerate(args.logs):
            progress.stage(f"{path}: reading the log, its bursts and its coast probes ({k + 1}/{len(args.logs)})")
            log = benchlog.read_log(path)
            for beside, what in ((rf.path_for(path), "current bursts"), (coast_file.path_for(path), "coast probes")):
                if not beside.exists():
                    raise InputError(f"{path}: no {what} beside it ({beside.name} expected; docs/bench-log.md)")
            bursts = rf.read(rf.path_for(path))
            probes = coast_file.read(coast_file.path_for(path))
            if model is not None:
                ra, ke = float(model.physics.ra_ohm), float(model.physics.ke_vs_per_rad)
            else:
                ra = args.ra_ohm if args.ra_ohm is not None else _meta_ra(path, log.meta)
                ke = float(args.ke_vs_per_rad)
            res = rc.estimate(log.df, bursts, probes, opts, ra, ke, copts)
            name = log.condition
            s = {"probes": len(probes), "statement": res.statement}
            if res.table is not None:
                tab = res.table
                tab[list(COAST_COLUMNS)].to_csv(stage / f"{name}.coast_probes.csv", index=False, float_format="%.6g")
                ok = tab["ra_ohm"].notna()
                tw = tab.loc[ok, "winding_C"].to_numpy(float)
                s.update({"ke_measured": int(tab["ke_vs_per_rad"].notna().sum()), "ra_given": int(ok.sum()),
                          "winding_given": int(np.isfinite(tw).sum()),
                          "ra_ref_ohm": res.ra_ref_ohm if np.isfinite(res.ra_ref_ohm) else None,
                          "ra_ref_C": res.ra_ref_C if np.isfinite(res.ra_ref_C) else None,
                          "reasons": {r: int(n) for r, n in tab.loc[tab["reason"] != "", "reason"].value_counts().items()}})
                line = (f"{name}: {len(probes)} coast probes; Ke measured at {s['ke_measured']}, Ra at {s['ra_given']}, "
                        f"the winding's temperature at {s['winding_given']}")
                if np.isfinite(tw).any():
                    sd = tab.loc[ok, "winding_sd_K"].to_numpy(float)
                    s["winding_C"] = [float(np.nanmin(tw)), float(np.nanmax(tw))]
                    line += (f"; winding {np.nanmin(tw):.1f} .. {np.nanmax(tw):.1f} C (median standard uncertainty "
                             f"{np.nanmedian(sd):.2f} K)")
                print(line)
            if res.statement:
                print(f"{name}: {res.statement}")
            summary[name] = s
        benchlog.write_text_atomic(stage / "summary.json", benchlog.json_text(summary, indent=1, sort_keys=True,
                                                                                 default=float))
    return 0


def _meta_ra(path, meta: dict) -> float:
    """The log's ra_ohm metadata, or an InputError saying how to give Ra."""
    from ..logs.errors import InputError
    from ..ripple.log import number_or_nan
    ra = number_or_nan(meta.get("ra_ohm"))
    if not (ra > 0 and math.isfinite(ra)):
        raise InputError(f"{path}: no Ra: give --ra-ohm (a multimeter reading) or an ra_ohm metadata line")
    return ra


def _capture(path, opts, args, stage):
    """One current-only capture (a burst file without its bench log): its windows counted
    (ripple.capture.speed_of_bursts), written, summed up and said; (name, summary)."""
    import numpy as np

    from ..logs import ripple as rf
    from ..ripple import capture as ripple_capture

    ignored = [f for f, v in (("--ra-ohm", args.ra_ohm), ("--ke-vs-per-rad", args.ke_vs_per_rad),
                              ("--model", args.prior_model)) if v is not None]
    if ignored and not args.quiet:
        print(f"hpddo ripple: note: {path}: {', '.join(ignored)} not used: a capture without a bench log has "
              "no voltage for a back-EMF prior", file=sys.stderr)
    b = rf.read(path)
    est = ripple_capture.speed_of_bursts(b, opts, args.rpm_range, str(path))
    name = b.meta.get("condition") or path.name[:-len(rf.SUFFIX)]
    est[list(COLUMNS)].rename(columns={"rpm": "rpm_ripple"}).to_csv(stage / f"{name}.ripple_speed.csv", index=False,
                                                                   float_format="%.6g")
    conf = est["confident"].to_numpy()
    rpm = est["rpm"].to_numpy()[conf]
    s = {"windows": len(est), "confident": int(conf.sum()), "capture": True,
         "rpm_range": None if args.rpm_range is None else list(args.rpm_range),
         "reasons": {k or "confident": int(n) for k, n in est["key"].value_counts().sort_index().items()}}
    line = f"{name}: {len(est)} windows (a capture, no bench log), confident {conf.sum()} ({conf.mean():.1%})"
    if conf.any():
        s["rpm_median"] = float(np.median(rpm))
        s["confidence_median"] = float(np.median(est["confidence"].to_numpy()[conf]))
        line += (f"; {s['rpm_median']:.4g} RPM (median of the confident; {rpm.min():.4g} to {rpm.max():.4g}), "
                 f"confidence {s['confidence_median']:.2f}")
    line += "; prior: " + (f"the speed range {args.rpm_range[0]:g}..{args.rpm_range[1]:g} RPM" if args.rpm_range
                           else "none (the comb alone)")
    print(line)
    if not args.quiet:
        print(_no_estimate(est, s["reasons"]), file=sys.stderr)
    return name, s


ABSOLUTE_ZERO_C = -273.15


def _one_name_each(names: dict) -> None:
    """Refuses two logs of one condition ({path: condition}): each writes OUT/<condition>.ripple_speed.csv and its
    summary under that name, so one would be lost (as train and diagnose refuse them)."""
    from ..logs.errors import InputError

    seen = {}
    for path, name in names.items():
        if name in seen:
            raise InputError(f"{path} and {seen[name]} are both condition {name!r}; each writes "
                             f"OUT/<condition>.ripple_speed.csv: give each recording its own # condition=")
        seen[name] = path


def _no_estimate(est, reasons: dict) -> str:
    """The lines that say why windows have no confident estimate: the count of each key, and the commonest key's
    reason in full, from its first window (the counts alone do not say what to do: a `rival` from an undeclared line
    and one from a sideband partner want different things of the user)."""
    keys = {k: n for k, n in reasons.items() if k != "confident"}
    said = "  no estimate: " + ", ".join(f"{k} {n}" for k, n in keys.items())
    if not keys:
        return said
    top = max(keys, key=lambda k: (keys[k], k))
    first = est.index[est["key"].to_numpy() == top][0]
    return (said + f"\n  {top} ({keys[top]} windows), window {est.index.get_loc(first)} for one: "
            f"{est.at[first, 'reason']}")


def _commutator(est) -> dict:
    """The commutator's health over a log's windows (ripple.comb.health): the windows where
    it was read, those where it was judged (their rotation comb places the lines: `multiple` > 0; a window without
    a comb reads them where the figure given puts the rotation, and names nothing), those named damaged, the
    median and largest power at twice the rotation frequency relative to the commutation line over the judged
    windows, and a statement."""
    import numpy as np

    from ..ripple import comb as rc

    r2 = est["rot2_rel"].to_numpy(float)
    read = np.isfinite(r2)
    judged = read & (est["multiple"].to_numpy(float) > 0 if "multiple" in est else True)
    bad = int((est["key"] == "damaged").sum())
    out = {"windows_read": int(read.sum()), "windows_judged": int(judged.sum()), "windows_damaged": bad,
           "rot2_rel_max_allowed": rc.HEALTH_ROT2_MAX,
           "rot2_rel_median": float(np.median(r2[judged])) if judged.any() else None,
           "rot2_rel_max": float(np.max(r2[judged])) if judged.any() else None}
    unjudged = read & ~judged
    over = unjudged & (r2 > rc.HEALTH_ROT2_MAX)
    aside = (f"; {int(over.sum())} of the {int(unjudged.sum())} windows without a rotation comb read up to "
             f"{np.max(r2[over]):.3g} at the rotation the figure given puts, which no comb confirms: not judged"
             if over.any() else "")
    if not read.any():
        out["statement"] = "the commutator's health not read (no window resolves the rotation's lines)"
    elif not judged.any():
        out["statement"] = ("the commutator's health not judged: no window's lines form a rotation comb, which places "
                            "the lines at once and twice the rotation frequency" + aside)
    elif bad:
        dmg = est["key"].to_numpy() == "damaged"
        r1 = est["rot1_rel"].to_numpy(float)
        fault = est["fault_rel"].to_numpy(float) if "fault_rel" in est else np.full(len(est), np.nan)
        uneven = all(rc.uneven_only(a, b, c) for a, b, c in zip(r1[dmg], r2[dmg], fault[dmg]))
        out["statement"] = (f"the commutator looks {'uneven' if uneven else 'damaged'} in {bad} of {judged.sum()} "
                            f"windows judged (the line at twice the rotation frequency up to {out['rot2_rel_max']:.3g} "
                            f"of the commutation line's power, over {rc.HEALTH_ROT2_MAX:g}): "
                            + ("a worn bar, or coils a few % unequal as in a healthy motor, or a smooth modulation twice "
                               "a revolution (a rotor's or a load's), which this line does not tell apart" if uneven else
                               "a worn or burnt bar, a shorted coil (its lines between the commutation line and its "
                               f"second harmonic up to {np.nanmax(fault[dmg]):.3g} of the line, over "
                               f"{rc.HEALTH_FAULT_MAX:g}, or the lines once or twice a revolution)"
                               if np.isfinite(fault[dmg]).any() else "a worn or burnt bar, a shorted coil")
                            + "; those windows are not counted" + aside)
    else:
        out["statement"] = (f"the commutator looks healthy ({judged.sum()} windows judged, the line at twice the "
                            f"rotation frequency at most {out['rot2_rel_max']:.3g} of the commutation line's power, "
                            f"under {rc.HEALTH_ROT2_MAX:g})" + aside)
    return out


def _calibrate(args, opts) -> int:
    """hpddo ripple --calibrate: the ripples per revolution of each log from its data
    (calibrate.calibrate), printed and written to OUT/summary.json."""
    import numpy as np

    from .. import progress
    from ..logs import benchlog, dataset, outdir
    from ..logs import ripple as rf
    from ..logs.errors import InputError
    from ..ripple import calibrate as rcal

    summary = {}
    with outdir.staged(args.out, TOOL) as stage:
        for k, path in enumerate(args.logs):
            progress.stage(f"{path}: finding the ripples per revolution ({k + 1}/{len(args.logs)})")
            if path.name.endswith(rf.SUFFIX):  # a current-only capture (hpddo import): its combs alone, every window
                b = rf.read(path)  # taken as driven, no encoder
                name = b.meta.get("condition") or path.name[:-len(rf.SUFFIX)]
                c = rcal.calibrate(b, np.ones(len(b)), opts, None)
                summary[name] = c
                print(f"{name}: {c['statement']}")
                continue
            log = benchlog.read_log(path)
            bpath = rf.path_for(path)
            if not bpath.exists():
                raise InputError(f"{path}: no current bursts beside it ({bpath.name})")
            b = rf.read(bpath)
            seq = log.df["seq"].to_numpy() if "seq" in log.df else np.arange(len(log.df))
            pos = {int(v): j for j, v in enumerate(seq)}
            rows = [pos.get(int(v)) for v in b.seq]
            if any(r is None for r in rows):
                raise InputError(f"{bpath}: a burst's seq is not in {path}")
            ref = None
            if "rpm_ref" in log.df and np.isfinite(log.df["rpm_ref"].to_numpy(float)).any():
                glitch, _ = dataset.glitch_mask(log.df)
                ref = np.where(glitch, np.nan, log.df["rpm_ref"].to_numpy(float))[rows]
            c = rcal.calibrate(b, log.df["duty"].to_numpy(float)[rows], opts, ref)
            summary[log.condition] = c
            print(f"{log.condition}: {c['statement']}")
        benchlog.write_text_atomic(stage / "summary.json", benchlog.json_text(summary, indent=1, sort_keys=True,
                                                                                 default=float))
    return 0


def main(argv=None) -> int:
    from . import run as run_subcommand
    return run_subcommand(TOOL, argv)
