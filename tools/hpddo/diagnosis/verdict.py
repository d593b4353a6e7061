"""The verdict's text: what the stages found, said in sentences (the named effects with their sizes, Ra,
the confounded pairs and what separates them, the dynamics, what the data cannot tell).
"""
from __future__ import annotations

import math

from ..model import effects as fx
from . import channels, intervals, noise, ranking
from .result import (ConfoundedPair, Confounding, EffectResult, RaFit, ResidualAnalysis, Residuals, Selection,
                     _alone, _with)


RATES = ("dI/dt", "dV/dt")  # the inputs no steady-state table has

# A residual correlated with a rate of change by |r| >= DYNAMICS_R follows the motor's dynamics:
# the speed lags the voltage through inertia and friction, the current through the winding's
# inductance. Measured on the twin's ideal bench (seed 3): at 50 Hz the sweep's residual follows
# dI/dt at r = -0.52 (sweep and load: -0.46); the bundled recordings at 2 Hz, whose residual is
# the thermal effects', follow dV/dt at -0.36 (the rows of a duty step).
DYNAMICS_R = 0.45

# ... on rows DYNAMICS_MAX_DT_S apart or closer (20 Hz and up): at 2 Hz the motor's time constants
# (tens of ms) are over within a row, and a residual following dI/dt (r = -0.50 on the ideal twin's
# sweep and long) is the few rows of a duty step, at the noise floor.
DYNAMICS_MAX_DT_S = 0.05

# The lags at which a rate of change (the backward difference) shares a row's reading with the residual:
# lag 0 (X(k) - X(k-1)) and lag -1 (X(k+1) - X(k)).
SHARED_LAGS = (0, -1)

ENCODER_NEEDS = ("speed from encoder periods (the time between counts) or counts over longer windows, or an encoder "
                 "with more counts per revolution")


#: a data-alone Ra this many times the reading (or under its inverse) is a reading's mistake (its unit, the leads)
#: even where the model misses something: within it, a missing effect can stand in for the difference (an independent
#: probe's levelling saturation put Ra at 0.61 times a right reading)
RA_GROSS = 2.0
#: where a structured residual remains, what the Ra sentence says instead of an Ra to pass
LEFT_NO_RA = ("; these recordings give no Ra to pass: a structured residual remains that no library effect "
              "explains (below), and a missing effect can stand in for a wrong Ra")


def ra_verdict(ra: RaFit | None, named=()) -> str:
    """The verdict's sentence on Ra; "" when the reading fits (or the data cannot tell). With a
    faulty current channel, no instruction on Ra: what the recordings seem to say of it rests on
    the readings that channel spoils. named: the effects the verdict names."""
    text = _ra_verdict(ra, named)
    if ra is not None and ra.current_fault and text and (ra.mismatch or any(w in text for w in ("--ra-ohm", NO_RA_TO_PASS))):
        return (f"Whether the Ra you gave ({ra.given_ohm:.3g} ohm) is right cannot be concluded from these "
                f"recordings: {ra.current_fault} (Channel health, below), and Ra rests on it; the effects were "
                "looked for with the reading.")
    return text


def _so_named(confounded, named) -> str:
    """What is named of the effects a wrong Ra explains as well as (RaFit.confounded_with), where the reading is
    kept: none of them, or those the verdict names all the same (a later stage named them at the reading's Ra),
    said as such: a fuzzing round's "... so none of them is named" stood beside "Missing: magnet_thermal"."""
    both = [e for e in confounded if e in named]
    if not both:
        return f"so {'neither' if len(confounded) == 1 else 'none of them'} is named"
    rest = [e for e in confounded if e not in both]
    return (f"and {' and '.join(both)} {'is' if len(both) == 1 else 'are'} named below at the size "
            f"{'it takes' if len(both) == 1 else 'they take'} with the Ra you gave (with another Ra, another or none)"
            + (f", {' and '.join(rest)} not" if rest else ""))


# (the plain branch's words where the data-alone Ra is no value to pass: a faulty current channel's sentence replaces
# them, as it does an instruction)
NO_RA_TO_PASS = "is no Ra to pass"


def _ra_verdict(ra: RaFit | None, named=()) -> str:
    if ra is None:
        return ""
    if not ra.determined:
        if not ra.confounded_with:
            return ""
        return (f"An error proportional to the current remains that a wrong Ra explains as well as "
                f"{' or '.join(ra.confounded_with)}, {_so_named(ra.confounded_with, named)}; whether the Ra you gave "
                f"({ra.given_ohm:.3g} ohm) is right cannot be told: Ra is not determined "
                f"by these recordings{_with(ra)} ({ra.data.why}); the effects were looked for with the reading. What would "
                f"determine Ra: {ra.data.needs}; to separate them: {ranking.RA_SEPARATOR}.")
    if not ra.mismatch and not ra.confounded_with:
        d = ra.data
        if ra.reading_inside or not ra.data_beyond(ranking.RA_PLAUSIBLE_SIGMAS):  # the whole interval beyond it
            return ""  # within what a reading's error and the held-out test leave open: the summary says it
        gross = not (1.0 / RA_GROSS <= d.value / ra.given_ohm <= RA_GROSS)
        if ra.residual_left and gross:  # a unit's or the leads' mistake, but no value to pass: the model misses something
            return (f"The Ra you gave ({ra.given_ohm:.3g} ohm) is not what these recordings show: {_alone(ra)}, "
                    f"{d.value / ra.given_ohm:.3g} times the reading: check the reading (its unit, the leads' "
                    f"resistance) and re-measure it{LEFT_NO_RA}; the effects were looked for with the reading and "
                    "may be wrong.")
        if ra.residual_left:  # the model the data-alone Ra rests on misses something: no claim on the reading
            return (f"{_alone(ra)[0].upper()}{_alone(ra)[1:]}, {d.value / ra.given_ohm:.3g} times the Ra you gave "
                    f"({ra.given_ohm:.3g} ohm), beyond what the error of a reading explains "
                    f"({ranking.RA_PLAUSIBLE_SIGMAS * ra.tolerance:.0%}); but a structured residual remains that no "
                    "library effect explains (below), and a missing effect can stand in for a wrong Ra, so whether "
                    "the reading is wrong cannot be told from these recordings: check the reading (its unit, the "
                    "leads' resistance); the effects were looked for with it.")
        if ra.supported_at_bound:  # the held-out test could not reach the data's Ra (its prior's range ends first)
            return (f"The Ra you gave ({ra.given_ohm:.3g} ohm) is not what these recordings show: {_alone(ra)}, "
                    f"{d.value / ra.given_ohm:.3g} times the reading, beyond what the error of a reading explains "
                    f"({ranking.RA_PLAUSIBLE_SIGMAS * ra.tolerance:.0%}); the effects were looked for with the "
                    "reading and may be wrong: check the reading (its unit, the leads' resistance), or pass "
                    f"--ra-ohm {d.value:.3g} if you trust these recordings.")
        # the held-out test reached the data's Ra and did not take it: the data-alone value rests on the model
        # fitted beside it, and moving Ra does not predict the held-out rows better, so no value to pass (an
        # independent probe's large motor, its reading right: "pass --ra-ohm 0.239" for 0.35 ohm)
        return (f"{_alone(ra)[0].upper()}{_alone(ra)[1:]}, {d.value / ra.given_ohm:.3g} times the Ra you gave "
                f"({ra.given_ohm:.3g} ohm), beyond what the error of a reading explains "
                f"({ranking.RA_PLAUSIBLE_SIGMAS * ra.tolerance:.0%}); but moving Ra from the reading does not "
                "predict the held-out rows better, so that value rests on the model fitted beside it and "
                f"{NO_RA_TO_PASS}: whether the reading is wrong is not concluded from these recordings; the effects were "
                f"looked for with the reading. To settle Ra: {ranking.RA_SEPARATOR}.")
    rel = ra.supported_ohm / ra.given_ohm - 1.0
    alone = f" ({_alone(ra)})" if ra.data is not None else ""
    if not ra.mismatch:
        return (f"An error proportional to the current remains that a wrong Ra{alone} explains as well as "
                f"{' or '.join(ra.confounded_with)}, {_so_named(ra.confounded_with, named)}; to separate them: "
                f"{ranking.RA_SEPARATOR}.")
    if ra.confounded_with:
        # an instruction only where it holds across the models that explain the rows about as well: with
        # Ra at the reading, each effect of confounded_with does (core.select, core.robust_ra): no --ra-ohm
        others = " or ".join(ra.confounded_with)
        # an effect named beside the corrected Ra (select: named beyond Ra) and told from a wrong Ra by neither: it is
        # named at the size it takes with Ra corrected (an independent probe's brush drop, Ra given 10 % low, was
        # "neither is named" beside "Missing: brush_drop")
        both = [e for e in ra.confounded_with if e in named]
        if both:
            which = (f"so the mismatch is no instruction, and {' and '.join(both)} {'is' if len(both) == 1 else 'are'}"
                     f" named below at the size {'it takes' if len(both) == 1 else 'they take'} with Ra at "
                     f"{ra.supported_ohm:.3g} ohm (with the reading, another)")
        else:
            which = (f"so {'neither' if len(ra.confounded_with) == 1 else 'none of them'} is named as an effect (the "
                     f"effects were looked for with Ra at {ra.supported_ohm:.3g} ohm)")
        return (f"The Ra you gave ({ra.given_ohm:.3g} ohm) does not fit these recordings unless {others} is at work"
                f"{alone}: with the reading's {ra.tolerance:.0%} tolerance as a prior and none of them, they support "
                f"{ra.supported_ohm:.3g} ohm ({rel:+.1%}, {abs(ra.sigmas):.1f}x the tolerance), an error proportional "
                f"to the current. These recordings cannot tell a wrong Ra from {others}, {which}; to separate them: "
                f"{ranking.RA_SEPARATOR}. hpddo train uses the Ra it is given: the next commands below are one for "
                "each model that fits.")
    return (f"The Ra you gave ({ra.given_ohm:.3g} ohm) does not fit these recordings{alone}: with the reading's "
            f"{ra.tolerance:.0%} tolerance as a prior they support "
            f"{ra.supported_ohm:.3g} ohm ({rel:+.1%}, {abs(ra.sigmas):.1f}x the tolerance), an error "
            "proportional to the current; the effects were looked for with Ra at that value. hpddo train still "
            "uses the Ra given: re-measure Ra" + (f"{LEFT_NO_RA}." if ra.residual_left else
                                                  f", or pass --ra-ohm {ra.supported_ohm:.3g} if you trust these "
                                                  "recordings."))

# the note of an effect named only with a recording that disagrees with the rest (core.resting_on)
RESTS_ON = "named only with the recording that disagrees with the rest"


# the note of an effect whose whole interval holds zero (core.through_zero)
HOLDS_ZERO = "holds zero"
# ... once the doubt on the Ra given is counted (core.through_zero)
HOLDS_ZERO_WITH_RA = "holds zero once the tolerance of the Ra given is counted"
# ... once the doubt on the Ra given is counted, where the data alone put Ra outside the reading (core.through_zero)
HOLDS_ZERO_RA_DOUBTED = "holds zero once the doubt on the Ra given is counted"
# the note of an effect whose final coefficient is on or beyond its physical range (core.unphysical)
UNPHYSICAL = "with the other named effects fitted alongside reaches the end of what the effect can be"
# the note of an effect whose whole interval lies outside its plausible range (core.beyond_plausible)
BEYOND = "lies outside the range the effect takes on a motor"
# the note of an effect that explained the held-out rows only beside effects no longer named (core.only_beside)
ONLY_BESIDE = "explained the held-out rows only beside"


def _range(e, which: str) -> str:
    eff = fx.LIBRARY[e.effect]
    return intervals._rng(getattr(eff, which), eff.show_scale, eff.show_unit)


# why a selected effect is not named, by the mark in its ranking row's note (core.not_named's callers)
NOT_NAMED = (
    (HOLDS_ZERO_WITH_RA, lambda e: f"its {100 * intervals.LEVEL:.0f} % interval holds zero once the tolerance of "
                                   "the Ra given is counted: a wrong Ra within that tolerance explains these "
                                   f"recordings as well, so it is not named; to tell them apart, "
                                   f"{ranking.RA_SEPARATOR}."),
    (HOLDS_ZERO_RA_DOUBTED, lambda e: f"its {100 * intervals.LEVEL:.0f} % interval holds zero once the doubt on the "
                                      "Ra given is counted (the data alone put Ra beyond the reading's tolerance "
                                      "without it): its size rests on a reading these recordings do not bear out, so "
                                      f"it is not named; to settle Ra, {ranking.RA_SEPARATOR}."),
    (HOLDS_ZERO, lambda e: f"its {100 * intervals.LEVEL:.0f} % interval holds zero, so these recordings do not "
                             "tell it from its absence: not named."),
    (UNPHYSICAL, lambda e: f"with the other named effects fitted alongside it is {_final(e)}, at the end of "
                           f"the {_range(e, 'physical')} it can take, or beyond: the fit traded it against them, "
                           "so it is not named."),
    (BEYOND, lambda e: f"its {100 * intervals.LEVEL:.0f} % interval lies outside the {_range(e, 'plausible')} it "
                       "takes on a motor: its term stands for something else these recordings hold, so it is not "
                       "named."),
    (ONLY_BESIDE, lambda e: f"it was selected beside {_beside(e)}, "
                            f"{'which are' if ',' in _beside(e) else 'which is'} not named, and without "
                            f"{'them' if ',' in _beside(e) else 'it'} the model with it predicts the held-out rows "
                            "worse than the model without it: not named."),
    (RESTS_ON, lambda e: "only with the recording that disagrees with the rest (below); without it, it is not: "
                         "not named."),
    (channels.BLIND_NOTE, lambda e: f"it acts through the {fx.LIBRARY[e.effect].reads} channel, which is stuck, or "
                                    "flat within one step, in every recording (Channel health, below): not named."),
)


def _final(e) -> str:
    """The coefficient with which a demoted effect's note says it left its range (core.unphysical's
    note: "fitted <value>, which ...")."""
    return e.note.split(", which", 1)[0].removeprefix("fitted ")


def _beside(e) -> str:
    """The effects beside which a demoted effect was selected (core.only_beside's note:
    "... only beside <names> (...)")."""
    return e.note.split(ONLY_BESIDE + " ", 1)[-1].split(" (", 1)[0]


def _why_not_named(e) -> str:
    """The sentence's end for a selected effect that is not named ("" for any other row)."""
    return next((say(e) for mark, say in NOT_NAMED if e.note and mark in e.note), "")


def verdict(sel: Selection, conf: Confounding, resid: Residuals, sigma2: float,
            floor: noise.NoiseFloor | None = None, family=None) -> str:
    """The verdict's text; family: the dynamic family from the fast recordings (dynamics.Dynamics)."""
    ra = ra_verdict(sel.ra_fit, sel.missing)
    text = _verdict(sel, conf, resid, sigma2, floor)
    held = [e for e in sel.ranking if e.kind == "candidate" and e.note and _why_not_named(e)]
    if held and text.startswith("No library effect explains the residual"):  # one was selected: said below
        text = "No library effect is named for the residual" + text[len("No library effect explains the residual"):]
    for e in held:  # selected by its held-out gain, but not named (core.through_zero, unphysical, ...)
        text += f" {e.effect} was selected ({e.shown}), but {_why_not_named(e)}"
    dyn = dynamics(resid.before, resid.dt_s, family)
    if dyn and family is not None and family.fast:  # the dynamics are named: no "no library effect explains it"
        for said, say in (("No library effect explains the residual", "Apart from the dynamics (above), no library "
                                                                        "effect is named for the residual"),
                          ("A structured residual remains that no library effect explains",
                           "A structured residual remains beyond the named effects and the dynamics (above)")):
            text = text.replace(said, say)
    if dyn:
        if text.startswith(NOTHING):  # the floor from row-to-row differences holds the dynamics' fast error
            text = ("No library effect is named; the residual is within the floor measured from row-to-row "
                    "differences, which on this recording holds the dynamics' own fast error." + text[len(NOTHING):])
        text = f"{dyn} {text}"
    if floor is not None and floor.limited_by_sensors:
        text += (" The sensors set the noise floor (" + ", ".join(f"{k} {math.sqrt(v):.3g} RPM" for k, v in
                                                           floor.sensors.items())
                 + f"; measured on the residual {math.sqrt(floor.measured_rpm2):.3g} RPM): an effect smaller than "
                 f"{math.sqrt(floor.var_rpm2):.3g} RPM cannot be seen on these rows.")
    if floor is not None and floor.truncated:
        text += f" Ke and Ra are not determined: {floor.truncated}; what would: {ENCODER_NEEDS}."
    return f"{ra} {text}" if ra else text


NOTHING = "Nothing missing: the residual is consistent with measurement noise."
NAMED_DYNAMICS = "Named: dynamics"  # the verdict names the dynamic family (hpddo train --dynamics)


def dynamics(before: ResidualAnalysis, dt_s: float, family=None) -> str:
    """The verdict's sentence on dynamics: when the model under test's residual is correlated
    with a rate of change (RATES) beyond its band by |r| >= DYNAMICS_R, the strongest one's r
    and lag, and, from recordings at 50 Hz and up (family: dynamics.Dynamics), the dynamic
    family identified (J, B, Tc, La with intervals), the speed's measured lag and the held-out
    RMSE before and after the family; "" otherwise."""
    top = max((c for c in before.correlates if c["significant"] and c["input"] in RATES),
              key=lambda c: abs(c["peak"]), default=None)
    if top is None or abs(top["peak"]) < DYNAMICS_R or not dt_s <= DYNAMICS_MAX_DT_S:
        return ""
    lag = top["peak_lag"]
    if family is not None and family.fast:
        text = (f"The residual follows {top['input']} (r = {top['peak']:+.2f} at a lag of {lag} rows, "
                f"{lag * dt_s * 1e3:+.0f} ms). {NAMED_DYNAMICS} (inertia and friction, the winding's inductance), "
                "which M2 does not carry: it is algebraic in V and I, the speed's lag is in the current. "
                + family.text())
        if lag in SHARED_LAGS:
            text += (f" At a lag of {lag} rows the rate's difference holds the row's own reading (dX/dt of row k + 1 "
                     "is (X(k+1) - X(k)) / T), so the channel's noise, in the residual and in the rate, correlates "
                     "there by itself (docs/dynamics.md).")
        return text + (" Effects named on this recording may stand in for the dynamics: confirm them on settled "
                       "rows (a 2 Hz recording).")
    return (f"The residual follows {top['input']} (r = {top['peak']:+.2f} at a lag of {lag} rows, "
            f"{lag * dt_s * 1e3:+.0f} ms): the speed lags the voltage through the motor's dynamics (inertia and "
            "friction, and the winding's inductance), which the library does not model at this rate; effects "
            "named on this recording may stand in for them: confirm them on settled rows (a 2 Hz recording).")


ABOVE_SHARE = ranking.ABOVE_SHARE


def structured_residual(after: ResidualAnalysis, sigma2: float) -> bool:
    """Whether the residual after the named effects is above the noise floor (ABOVE_SHARE) and not white:
    something the library does not hold is at work."""
    return after.excess > ABOVE_SHARE * sigma2 and after.whiteness["white"] is False


def _verdict(sel: Selection, conf: Confounding, resid: Residuals, sigma2: float,
             floor: noise.NoiseFloor | None = None) -> str:
    after = resid.after
    above = after.excess > ABOVE_SHARE * sigma2
    structured_left = structured_residual(after, sigma2)
    if not sel.missing:
        if above and sel.ra_fit is not None and sel.ra_fit.confounded_with and not sel.ra_fit.mismatch:
            # the sentence before this one names what explains it: a wrong Ra or the effects it cannot be told from
            return (f"With Ra held at the reading and none of them named, the residual stays "
                    f"{after.excess / max(sigma2, 1e-12):.1f}x the noise variance above the noise floor: the "
                    "measurement named above settles which of them it is; the next commands below are one for each "
                    "model that fits.")
        if floor is not None and floor.from_model and above and floor.bound_evidence:
            # the floor is what the selected model leaves out of fold: a residual this far above it is something
            # the recordings hold that no named effect explains (what was selected and not named, said after this)
            whose = ("the model with every library effect" if floor.source.startswith(noise.FROM_ALL_EFFECTS)
                     else "the selected model")
            return ("No library effect is named for the residual, which stays "
                    f"{after.excess / max(sigma2, 1e-12):.1f}x the noise variance above the floor "
                    f"({math.sqrt(floor.measured_rpm2):.3g} RPM, what {whose} leaves out of fold: "
                    f"{floor.unmeasured[0]}): something these recordings hold is missing from the model.")
        if floor is not None and floor.from_model:
            return ("No library effect is named. Whether anything is missing below "
                    f"{math.sqrt(floor.measured_rpm2):.3g} RPM cannot be told: {floor.unmeasured[0]}, so its "
                    f"noise floor is what the model leaves out of fold; {floor.unmeasured[1]}.")
        if above and after.whiteness["white"] is None:
            return ("No library effect explains the residual, which is "
                    f"{after.excess / max(sigma2, 1e-12):.1f}x the noise variance above the noise floor; whether "
                    f"it is structured cannot be tested ({after.whiteness.get('not_computed', 'no whiteness test')}).")
        if structured_left:
            return ("No library effect explains the residual, but it is not noise: it is "
                    f"{after.excess / max(sigma2, 1e-12):.1f}x the noise variance above the noise floor "
                    "and not white. " + _correlates(after))
        corrected = sel.ra_fit is not None and sel.ra_fit.mismatch
        if above:  # white (a structured or an untested residual is said above): above the floor all the same
            return (f"No library effect is named{' once Ra is corrected' if corrected else ''}, but the residual is "
                    f"not measurement noise: it stays {after.excess / max(sigma2, 1e-12):.1f}x the noise variance "
                    "above the noise floor, white, so no library effect's structure shows in it: an effect outside "
                    "the library, a channel's gain or an operating point the model does not hold; or a floor "
                    "measured too low (a speed channel smoothed from row to row).")
        if corrected:
            return "No effect missing once Ra is corrected: the residual is then consistent with measurement noise."
        return NOTHING
    text = "Missing: " + ", ".join(f"{e.effect} ({_size(e)})" for e in sel.ranking if e.named) + "."
    if conf.groups:
        text += " " + " ".join(_pair_sentence(s) for s in conf.pairs if ranking.RA_MISMATCH not in s.effects)
    if conf.told_apart:
        text += " " + " ".join(
            f"{a['effects'][1]} explains much of what {a['effects'][0]} does, but these recordings tell "
            f"the two apart (z = {a['z']:.1f})." for a in conf.told_apart)
    if structured_left:
        sig = [c for c in after.correlates[:3] if c["significant"]]
        text += (" A structured residual remains that no library effect explains "
                 f"({after.excess / max(sigma2, 1e-12):.1f}x the noise variance)"
                 + ("; strongest correlates: " + ", ".join(f"{c['input']} (r = {c['peak']:+.2f})" for c in sig) + "."
                    if sig else ". " + _correlates(after)))
    return text


def _correlates(after: ResidualAnalysis) -> str:
    """The residual's strongest significant correlates among the logged inputs, as a sentence; where none is
    significant, that none is (what drives the residual is not among the logged inputs)."""
    sig = [c for c in after.correlates[:3] if c["significant"]]
    if not sig:
        return ("None of the logged inputs correlates with it beyond its band: what drives it is not among "
                f"them ({', '.join(c['input'] for c in after.correlates) or 'none tested'}).")
    return "Its strongest correlates: " + ", ".join(
        f"{c['input']} (r = {c['peak']:+.2f} at lag {c['peak_lag']})" for c in sig) + "."


def _size(e: EffectResult) -> str:
    """A named effect's size in words: its value and interval, or that the recordings do not
    determine it (its coefficient's interval, intervals.Interval)."""
    iv = next((iv for iv in e.intervals if iv.field == fx.LIBRARY[e.effect].field), None)
    eff = fx.LIBRARY[e.effect]
    if iv is None and eff.material is not None:  # its coefficient held at its material's, not fitted
        return (f"{e.shown}, held at its material's coefficient ({eff.material_name}), not fitted: these recordings "
                "show the heating's effect, not its coefficient")
    if iv is None:
        return e.shown
    if not iv.determined:
        rng = (f": {100 * intervals.LEVEL:.0f} % interval {iv.lo * iv.show_scale:+.3g}..{iv.hi * iv.show_scale:+.3g} "
               f"{iv.show_unit}" if iv.lo is not None else "")
        return f"fitted {e.shown}, but its size is not determined by these recordings{rng}"
    text = f"{e.shown}, {100 * intervals.LEVEL:.0f} % interval {iv.lo * iv.show_scale:+.3g}..{iv.hi * iv.show_scale:+.3g}"
    if iv.lo <= 0.0 <= iv.hi and iv.half_without_ra is not None and abs(iv.value) > iv.half_without_ra:
        # named with an interval through zero: only the doubt on the Ra given takes it there (core.through_zero); for a
        # channel's calibration an Ra within that doubt was fitted without it, and missed (core.ra_stands_in)
        text += (", which reaches zero only through the doubt on the Ra given"
                 + (": an Ra within that doubt without it misses the held-out rows" if eff.calibration else
                    "; a re-measured Ra narrows it"))
    return text


def _pair_sentence(s: ConfoundedPair) -> str:
    text = (f"{' and '.join(s.effects)} cannot be told apart on these recordings; "
            f"a recording that would separate them: {s.recording}.")
    if s.more_data_x is not None and s.more_data_x > 1.0:
        # (two digits under 10: "about 1 times as much" read for 1.08, a fuzzing round's)
        x = f"{s.more_data_x:.2g}" if s.more_data_x < 10 else f"{s.more_data_x:.0f}"
        text += (f" These recordings hold a little of it (z = {s.z_apart:.1f}): about {x} times "
                 "as much of it would tell them apart.")
    return text
