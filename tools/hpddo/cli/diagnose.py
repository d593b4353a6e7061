"""Diagnoses the physics model against labelled bench logs and names the missing effects.

    hpddo diagnose LOG... --out DIR [--effects NAME,...] [options]   (tools/diagnose.py is the same)

Fits the physics model (plain M2, or M2 with --effects) on the training rows (first 80 %
of each recording), analyses its residual on the held-out rows (where the squared error
sits, whiteness, cross-correlation with V, I, duty, temperature), ranks the effects of the
library (tools/hpddo/model/effects.py) by the share of the held-out residual each explains,
says which are missing (or that nothing is), adds them, and reports the error before and
after for the physics model and for the hybrid retrained on top. Writes DIR/index.html
and DIR/diagnosis.json together, or nothing (a malformed log is refused with its file,
line and fault). See docs/diagnosis.md.
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

from . import options



def parser(prog: str = "hpddo diagnose") -> argparse.ArgumentParser:
    from ..diagnosis import core

    p = options.new_parser(prog, __doc__)
    options.logs(p)
    options.out(p, "output folder (index.html, diagnosis.json): new, empty, or a previous output of "
                   "hpddo diagnose")
    options.effects(p, "effects already in the model under test")
    options.ra_ohm(p)
    options.nameplate(p, "; the diagnosis does not use it: it passes it on to the hpddo train command it prints")
    options.ke_fit(p)
    p.add_argument("--bootstrap", type=options.non_negative_int, default=core.ranking.BOOTSTRAP, metavar="N",
                   help=f"block-bootstrap resamples for the inclusion frequency (default {core.ranking.BOOTSTRAP}; "
                        "0: none)")
    p.add_argument("--no-hybrid", action="store_true", help="skip retraining the hybrid before/after")
    p.add_argument("--epochs", type=options.positive_int, default=None, metavar="N",
                   help=f"training epochs of the hybrid before and after, no early stop (default {core.HYBRID_ITER}, "
                        f"fewer where the rows make more than {core.HYBRID_MAX_STEPS} Adam steps; given: N epochs "
                        "whatever the rows)")
    options.seed(p, "the bootstrap and the network")
    options.glitch_filter(p)
    options.leave_one_out(p)
    options.reference(p)
    options.quiet(p)
    return p


def options_of(args):
    """The diagnosis options a command line gives."""
    from ..diagnosis import core
    return core.Options(effects=args.effects, ra_ohm=args.ra_ohm, bootstrap=args.bootstrap,
                        hybrid=not args.no_hybrid, seed=args.seed,
                        **({} if args.epochs is None else {"hybrid_iter": args.epochs, "hybrid_max_steps": None}),
                        glitch_filter=not args.no_glitch_filter, leave_one_out=args.leave_one_out,
                        ke_fit=args.ke_fit, reference=options.reference_of(args))


def diagnose_into(logs, opt, out: pathlib.Path):
    """Runs the diagnosis and writes its report (index.html, diagnosis.json) into out,
    whole or not at all; returns the typed result (hpddo.diagnosis.Diagnosis)."""
    from ..logs import outdir
    from ..diagnosis import core
    from ..reports import diagnosis as report
    from .. import progress

    outdir.check(out, "diagnose")  # before the work: a refused folder costs nothing
    d = core.diagnose(logs, opt)
    progress.stage("writing the report")
    with outdir.staged(out, "diagnose") as stage:
        report.write(stage, d.to_json(), d.plot())
    return d


def summary(d) -> str:
    """The verdict, the named effects and the RMSE table, as the command prints them."""
    from ..diagnosis.ranking import FEW_BLOCKS
    from ..evaluation.metrics import table_cell

    from ..ripple import reference

    res = d.to_json()
    lines = [reference.line(r["name"], r["reference"]) for r in res.get("recordings", ()) if "reference" in r]
    if "reference" in res:
        lines.append(f"note: {reference.WEIGHTS_NOTE}")
    lines.append(res["verdict"])
    for e in res["ranking"]:
        if e["named"]:
            incl = "" if e["inclusion"] is None else f", inclusion {100 * e['inclusion']:.0f} %"
            if incl and res["thresholds"].get("bootstrap_blocks", 99) < FEW_BLOCKS:
                incl += f" (of {res['thresholds']['bootstrap_blocks']} operating points: means little)"
            lines.append(f"  {e['effect']:15s} {e['shown']:>14s}  score {e['score']:.3f}{incl}; {e['plausibility']}")
            if e.get("note"):
                lines.append(f"    {e['note']}")
            for iv in e.get("intervals", []):
                lines.append(f"    {iv['text']}")
    ra = res.get("ra_fit")
    if ra:
        lines.append(f"  Ra: {ra['statement']}")
    for iv in res.get("intervals", []):
        if iv["field"] == "ke_vs_per_rad":
            lines.append(f"  {iv['text']}")
    node = getattr(d, "thermal_node", None) or res.get("thermal_node") or {}
    fitted = {iv["field"]: iv for iv in res.get("intervals", [])}
    for which, lab in (("after_model", "with the missing effects"), ("model", "model under test")):
        if node.get(which):
            lines.append(f"  winding node ({node['path']} path, {lab}):")
            for q in node[which]:  # a value is a result only where the data determine it
                iv = fitted.get(q["field"])
                if iv is None or iv["determined"]:  # (no interval: a result without them, as before)
                    lines.append(f"    {q['field']:13s} {q['shown']:>14s}  {q['plausibility']}")
                else:
                    lines.append(f"    {q['field']:13s} not determined by these recordings ({iv['why']})")
            form = node.get("form")
            if form:
                lines.append(f"    {node_form_text(form)}")
            if node.get("profile"):
                lines.append(f"    {node_profile_text(node['profile'])}")
            break
    if res.get("noise_floor"):
        lines.append(f"  {res['noise_floor']['text']}")
    if (res.get("sensors") or {}).get("text"):
        lines.append(f"  sensors: {res['sensors']['text']}")
    for kind, what in (("steady_state", "steady-state tables, no lag, dI/dt or whiteness statistics"),
                       ("time_series", "read as time series")):
        recs = [r for r in res.get("recordings", []) if r.get("kind") == kind
                and (kind == "steady_state" or r.get("kind_source") != "declared")]
        by_source = {}  # how each kind is known (an undeclared one with the line that declares the other)
        for r in recs:
            by_source.setdefault(r["kind_source"], []).append(r["name"])
        for how, names in by_source.items():
            lines.append(f"  {what}: {', '.join(names)} ({how})")
    if (res.get("thresholds") or {}).get("held_out"):
        lines.append(f"  held out: {res['thresholds']['held_out']}")
    if (res.get("dynamics") or {}).get("text"):
        lines.append(f"  {res['dynamics']['text']}")
    for f in res.get("channels", []):
        lines.append(f"  channel: {f['channel']} of {f['recording']} {f['fault']} ({f['figure']})")
    for u in (res.get("consistency") or {}).get("units", []):
        if u["inconsistent"]:
            lines.append(f"  disagrees with the rest: {u['kind']} {u['name']}, {u['rmse_rpm']:.3g} RPM by the model "
                         f"identified without it (the others: {u['others_rpm']:.3g} RPM median)")
    conds = list(res["rmse_rpm"]["before"])
    lines.append("RMSE on the test parts (RPM)   " + " ".join(f"{c:>9s}" for c in conds))
    rows = [("physics before", res["rmse_rpm"]["before"]), ("physics after", res["rmse_rpm"]["after"])]
    if "rmse_rpm_hybrid" in res:
        rows += [("hybrid before", res["rmse_rpm_hybrid"]["before"]), ("hybrid after", res["rmse_rpm_hybrid"]["after"])]
    for lab, row in rows:
        lines.append(f"  {lab:28s}" + " ".join(table_cell(row[c], 9) for c in conds))
    if "leave_one_out" in res:
        loo = res["leave_one_out"]
        names = list(loo["recordings"]) + ["average"]
        lines.append("physics on each recording whole, fitted on the others (leave one out, RPM)")
        lines.append("  " + f"{'':28s}" + " ".join(f"{c:>9s}" for c in names))
        for w, lab in (("before", "physics before"), ("after", "physics after")):
            vals = [loo["recordings"][c][w] for c in names[:-1]] + [loo["average"][w]]
            lines.append(f"  {lab:28s}" + " ".join(table_cell(v, 9) for v in vals))
        for c in names[:-1]:
            if loo["recordings"][c].get("why"):
                lines.append(f"  ({c}: {loo['recordings'][c]['why']})")
    return "\n".join(lines)


def node_form_text(form: dict) -> str:
    """The line under the winding node on its other form (core.node_form_rival, diagnosis.json thermal_node.form)."""
    mse = form["held_out_mse_rpm2"]
    other = ("the node's other form (the winding following the case reading through the node's lag, where the "
             "boards' node takes the case's rise at once)")
    if form["as_well"]:
        return (f"its form: {other} explains the held-out rows as well (MSE {mse['lagging']:.4g} against "
                f"{mse['boards']:.4g} RPM^2): these recordings do not tell the two forms apart, and every interval "
                "reaches over both forms' values")
    return (f"its form: {other} misses the held-out rows by more (MSE {mse['lagging']:.4g} against {mse['boards']:.4g} "
            "RPM^2): the boards' form is kept")


def node_profile_text(profile: dict) -> str:
    """The line under the winding node on its time constant held at other values (core.node_profile,
    diagnosis.json thermal_node.profile)."""
    ok = [t["tau_s"] for t in profile["tried"] if t["as_well"]]
    out = [t["tau_s"] for t in profile["tried"] if not t["as_well"]]
    told = f"; {', '.join(f'{t:.3g}' for t in out)} s missed them by more" if out else ""
    if not ok:
        return (f"its time constant: held at other values ({', '.join(f'{t:.3g}' for t in out)} s), the model misses "
                f"the held-out rows by more than at {profile['fitted_tau_s']:.3g} s")
    span = f"{min(ok + [profile['fitted_tau_s']]):.3g}..{max(ok + [profile['fitted_tau_s']]):.3g} s"
    return (f"its time constant: held anywhere in {span} the model explains the held-out rows as well{told}; "
            "every interval reaches over those models' values")


def hybrid_note(d) -> str | None:
    """Why the diagnosis' hybrid figures are not hpddo train's M3 figures."""
    if d.hybrid is None:
        return None
    return (f"(hybrid: M3 retrained here for {d.hybrid.iterations} epochs on each physics model, to compare before "
            "and after; hpddo train trains it for 2000, so its M3 figures differ)")


def dynamics_named(res: dict) -> bool:
    """Whether the diagnosis (its JSON) names the dynamic family and the recordings determine J, B
    and Tc: then hpddo train --dynamics can add it."""
    from ..diagnosis.verdict import NAMED_DYNAMICS
    got = {q["field"]: q["determined"] for q in (res.get("dynamics") or {}).get("quantities", [])}
    return NAMED_DYNAMICS in (res.get("verdict") or "") and all(got.get(f) for f in ("j_kgm2", "b_nms_per_rad", "tc_nm"))


def next_steps(d, args) -> str:
    """What to type next: train with the named effects (and the Ra the data support, where
    they name a mismatch that no effect explains as well; where effects do, one command for each model
    that fits: the Ra the data support, and the Ra given with each such effect, to be chosen by a new
    reading of Ra: a fuzzed bench's reading 10 % high was passed on alone, 83 RPM on an unseen run
    against 5.5 with the true Ra), then score that model on a recording it never saw. Each option
    given here that hpddo train takes and that shapes the model is carried over (the nameplate, Ke's fit,
    the glitch filter, the reference); the diagnosis' own (--bootstrap, --epochs, --seed,
    --leave-one-out, --no-hybrid) are not train's."""
    import shlex

    res = d.to_json()
    lines = []
    ra = res.get("ra_fit") or {}
    effects = list(args.effects) + [e for e in res["missing_effects"] if e not in args.effects]
    dynamics = dynamics_named(res)
    ra_named = bool(ra.get("mismatch")) and not ra.get("confounded_with") and not ra.get("residual_left")
    # a mismatch that effects explain as well (the verdict: "does not fit ... unless X is at work"): the Ra the data
    # support and the reading with each such effect are the models that fit, and only a new reading tells which
    # (whatever residual is left: the verdict promises these commands there too; a fuzzing round's bench printed the
    # rejected reading alone under that promise)
    given = options.number_word(args.ra_ohm) if args.ra_ohm is not None else None
    supported = f"{ra['supported_ohm']:.4g}" if ra.get("supported_ohm") is not None else None
    # the Ke fit the report advises (core.ke_check: "Trust least squares (--ke-fit lsq)"), as the command's: it was
    # said in seven of a fuzzing round's reports whose next command kept eq. 20
    kc = res.get("ke_check") or {}
    ke_fit = "lsq" if (kc.get("disagree") or kc.get("biased")) and kc.get("ke_fit") != "lsq" else args.ke_fit
    from ..model.identify import KE_FITS
    from .train import hold_word
    held = {e: v for e, v in (res.get("held_effects") or {}).items() if e in effects}

    # a recording named another motor is left out of the ranking, and out of the model: trained on, it would pull
    # Ke between two motors (a fuzzing round's command listed it beside the recordings of the motor diagnosed)
    other = {pathlib.Path(o["file"]).resolve(): o["recording"]
             for o in (res.get("consistency") or {}).get("other_motors", []) if o.get("file")}
    logs = [p for p in args.logs if pathlib.Path(p).resolve() not in other]

    def train(ra_word, more=()):
        words = ["hpddo", "train", *map(str, logs), "--out", "MODEL"]
        names = effects + [e for e in more if e not in effects]
        if names:
            words += ["--effects", ",".join(names)]
        if held:  # the coefficients the diagnosis held at their material's (train would fit them free)
            words += ["--hold", hold_word(held)]
        if dynamics:
            words.append("--dynamics")
        if ra_word is not None:
            words += ["--ra-ohm", ra_word]
        for flag, v in (("--rated-v", args.rated_v), ("--rated-rpm", args.rated_rpm)):
            if v is not None:
                words += [flag, options.number_word(v)]
        if ke_fit != KE_FITS[0]:
            words += ["--ke-fit", ke_fit]
        if args.no_glitch_filter:
            words.append("--no-glitch-filter")
        return shlex.join(words + options.reference_words(args))

    from ..diagnosis.verdict import ABOVE_SHARE
    after = res.get("residual_after") or {}
    left = (after.get("excess") or 0.0) > ABOVE_SHARE * (after.get("noise_var") or float("inf"))
    # The same holds where no mismatch is concluded but a residual is left that a wrong Ra explains as well as
    # those effects (a fuzzing round's tiny motor, its reading 10 % high: the reading alone was printed, 113 RPM on
    # an unseen run against 32 at the true Ra).
    either = bool(ra.get("confounded_with")) and (bool(ra.get("mismatch")) or left) and supported is not None
    if either:
        others = list(ra["confounded_with"])
        lines.append(f"next (these recordings cannot tell a wrong Ra from {' or '.join(others)}: re-measure Ra, as "
                     "the verdict says, and train the model that holds with it):")
        row = " (the 'after' row above)" if ra.get("mismatch") else ""
        lines.append(f"  if the Ra you gave is wrong{row}:\n    {train(supported)}")
        for e in others:
            lines.append(f"  if it is right, with {e}:\n    {train(given, [e])}")
    elif ra.get("stand_ins") and not ra.get("mismatch"):
        # a channel's calibration left out because an Ra within the reading's doubt explains the rows as well
        # (core.ra_stands_in): both models fit, the reading alone with neither does not (an independent simulator's
        # voltage gain of -3 %: the model as it was left 1.35 RPM, either of the two 0.35)
        stand = ra["stand_ins"]
        lines.append(f"next (these recordings cannot tell a wrong Ra from {' or '.join(stand)}: re-measure Ra, as the "
                     "verdict says, and train the model that holds with it):")
        for e, ohm in stand.items():
            lines.append(f"  if the Ra you gave is off within its tolerance (not {e}):\n    {train(f'{ohm:.4g}')}")
            lines.append(f"  if it is right, with {e}:\n    {train(given, [e])}")
    else:
        what = ("add what the diagnosis named" if effects != list(args.effects) or ra_named or dynamics
                else "nothing named to add: the residual stays above the noise floor (the verdict above); the model "
                     "as it is" if left else "nothing to add: train the model as it is")
        lines.append(f"next ({what}):\n  {train(supported if ra_named else given)}")
    if other:
        lines.append(f"  (without {', '.join(sorted(other.values()))}: named another motor above; a model of it is "
                     "trained on it alone)")
    lines.append("then score it on a recording it never saw:\n  "
                 + shlex.join(["hpddo", "evaluate", "--model", "MODEL", "NEW_RUN.csv", "--out", "EVAL",
                               *options.reference_words(args)]))
    from ..model import effects as fx
    fitted = {iv["field"]: iv for iv in res.get("intervals", [])}
    loose = [e for e in res["missing_effects"] if e in fx.LIBRARY
             and not (fitted.get(fx.LIBRARY[e].field) or {}).get("determined", True)]
    if loose:  # named, but their size is open: said beside the command that adds them
        lines.append(f"  (the size of {', '.join(loose)} is not determined by these recordings: the model takes "
                     "what the fit finds; the diagnosis' intervals say how far it may be off)")
    return "\n".join(lines)


def run(args) -> int:
    t0 = time.perf_counter()
    d = diagnose_into(args.logs, options_of(args), args.out)
    for w in d.warnings:
        print(f"hpddo diagnose: WARNING: {w}", file=sys.stderr)
    print(summary(d))
    note = hybrid_note(d)
    if note:
        print(note)
    print(next_steps(d, args))
    if not args.quiet:
        print(f"wrote {args.out}/index.html and diagnosis.json; diagnosis took {time.perf_counter() - t0:.1f} s")
    return 0


def main(argv=None) -> int:
    """`hpddo diagnose ...`: parses argv, runs, reports a user error in one line; the exit status."""
    from . import run as run_subcommand
    return run_subcommand("diagnose", argv)
