"""The diagnosis's typed values: its options, each stage's result, and the Diagnosis with its JSON
(diagnosis.json).
"""
from __future__ import annotations

import dataclasses

from .. import schema
from ..model import effects as fx
from ..model import physics as ph
from . import channels, intervals, noise, ranking


HYBRID_ITER = 150  # training epochs of the hybrid in the diagnosis (hpddo train: 2000) ...
#: ... and its Adam steps at the most: an epoch over more rows takes more steps, and the network settles in about
#: as many steps whatever the rows, so a longer bench runs fewer epochs (150 epochs of 34 batches: the bundled
#: recordings' 6,759 training rows, which it leaves as they were)
HYBRID_MAX_STEPS = 5100


@dataclasses.dataclass
class Options:
    effects: tuple = ()          # effects already in the model under test
    ra_ohm: float | None = None
    bootstrap: int = ranking.BOOTSTRAP
    hybrid: bool = True
    hybrid_iter: int = HYBRID_ITER
    hybrid_max_steps: int | None = HYBRID_MAX_STEPS  # None: hybrid_iter epochs whatever the rows
    seed: int = 1
    glitch_filter: bool = True
    leave_one_out: bool = False  # also score the physics before/after on each recording, fitted on the others
    ke_fit: str = "eq20"         # Ke of M2: "eq20" (the paper's mean ratio) or "lsq" (least squares)
    consistency: bool = True     # check each recording (a table's operating groups) against the others
    reference: object | None = None  # the speed taken as rpm_ref (hpddo.ripple.reference.Ripple); None: the encoder


@dataclasses.dataclass
class EffectResult:
    """One row of the ranking table. kind: "named" (missing, named by the selection or the
    material check), "candidate" (identifiable, not named) or "unseen" (not identifiable)."""

    effect: str
    kind: str
    score: float
    params: dict
    inclusion: float | None = None
    shown: str = ""
    unit: str = ""
    plausible: bool = False
    plausibility: str = ""
    meaning: str = ""
    gain_rpm2: float | None = None
    z: float | None = None
    physical: bool | None = None          # candidate: its fitted coefficient is physical
    alone_gain_rpm2: float | None = None  # candidate: its gain on the base model alone
    note: str | None = None               # named by the material check
    se: float | None = None               # unseen: standard error of its coefficient
    needs: str = ""                       # unseen: the recording that would show it
    node: list = dataclasses.field(default_factory=list)  # thermal: its winding node's plausibility
    intervals: list = dataclasses.field(default_factory=list)  # named: its coefficient's and shapes' Interval

    @property
    def named(self) -> bool:
        return self.kind == "named"

    @property
    def identifiable(self) -> bool:
        return self.kind != "unseen"

    def at(self, p: ph.PhysicsParams, blind: bool = False) -> "EffectResult":
        """This row with its coefficient (and what is derived from it) read from p."""
        return dataclasses.replace(self, **_described(self.effect, p, blind))

    def to_json(self) -> dict:
        if not self.identifiable:
            return {"effect": self.effect, "score": self.score, "params": self.params, "named": False,
                    "identifiable": False, "inclusion": self.inclusion, "se": self.se, "meaning": self.meaning,
                    "plausibility": self.plausibility, "needs": self.needs}
        out = {"effect": self.effect, "params": self.params, "shown": self.shown, "unit": self.unit,
               "plausible": self.plausible, "plausibility": self.plausibility, "meaning": self.meaning,
               "score": self.score, "gain_rpm2": self.gain_rpm2, "z": self.z, "named": self.named,
               "inclusion": self.inclusion, "identifiable": True}
        if self.kind == "candidate":
            out.update(physical=self.physical, alone_gain_rpm2=self.alone_gain_rpm2)
        if self.node:
            out["thermal_node"] = self.node
        if self.intervals:
            out["intervals"] = [iv.to_json() for iv in self.intervals]
        if self.note is not None:
            out["note"] = self.note
        return out


def _described(name: str, p: ph.PhysicsParams, blind: bool = False) -> dict:
    """The fields of an EffectResult that follow from the parameters p (blind: some rows
    read no temperature, the winding node runs above ambient)."""
    eff = fx.LIBRARY[name]
    val = getattr(p, eff.field)
    ok, text = eff.plausibility(val)
    params = {eff.field: val}
    params.update((sh.field, float(getattr(p, sh.field))) for sh in eff.shapes)  # the form fitted
    widened = name in fx.widened_in(p, [name])
    for sh in eff.shapes:  # a form at the edge of those allowed (but the base form): not fixed by the data
        v, (lo, hi) = float(getattr(p, sh.field)), fx.shape_bounds(sh, widened)
        edge = lo if abs(v - lo) <= 1e-6 * (hi - lo) else hi if abs(v - hi) <= 1e-6 * (hi - lo) else None
        if edge is not None and edge != sh.default:
            text += (f"; its form ({sh.field} = {schema.quantity(v, sh.unit)}) is at the edge of those allowed "
                     f"({lo:g}..{schema.quantity(hi, sh.unit)}): these recordings do not fix it")
    node = []
    if eff.thermal and p.thermal_enabled():
        params.update(th_r_K_per_W=p.th_r_K_per_W, th_tau_s=p.th_tau_s)
        node = fx.node_plausibility(p, blind)
    return {"params": params, "shown": eff.show(val), "unit": eff.unit, "plausible": ok, "plausibility": text,
            "meaning": eff.meaning, "node": node}


def _score(gain: float, mse_base: float) -> float:
    return max(0.0, min(1.0, gain / mse_base))


@dataclasses.dataclass
class Trial:
    """One candidate tried at a step of the forward selection."""

    effect: str
    gain_rpm2: float
    z: float
    physical: bool

    def to_json(self) -> dict:
        return {"effect": self.effect, "gain_rpm2": self.gain_rpm2, "z": self.z, "physical": bool(self.physical)}


@dataclasses.dataclass
class RankingStep:
    """One step of the forward selection; effect None: the step that named nothing."""

    effect: str | None
    gain_rpm2: float
    z: float
    mse_before: float
    mse_after: float
    tried: list  # [Trial]

    @classmethod
    def of(cls, s: ranking.Step) -> "RankingStep":
        return cls(s.name or None, s.gain, s.z, s.mse_before, s.mse_after,
                   [Trial(a, g, z, phy) for a, g, z, phy in s.alternatives])

    def to_json(self) -> dict:
        return {"effect": self.effect, "gain_rpm2": self.gain_rpm2, "z": self.z, "mse_before": self.mse_before,
                "mse_after": self.mse_after, "tried": [t.to_json() for t in self.tried]}


@dataclasses.dataclass
class MaterialCheck:
    """The material check of `effect` (whose coefficient is a material constant) against
    `other` (the effect that shares its work)."""

    effect: str
    other: str
    fitted: float              # the freely fitted coefficient of `effect`
    held_out_mse_fitted: float
    held_out_mse_material: float  # with the material's value and `other`

    def to_json(self) -> dict:
        e, o = fx.LIBRARY[self.effect], fx.LIBRARY[self.other]
        return {f"{self.effect}_fitted_{e.unit.replace('1/', 'per_')}": self.fitted,
                "held_out_mse_fitted": self.held_out_mse_fitted,
                f"held_out_mse_{e.material_name}_plus_{o.material_name}": self.held_out_mse_material}


@dataclasses.dataclass
class ConfoundedPair:
    """Two effects the recordings cannot tell apart, and the recording that would."""

    effects: list
    recording: str
    corr: float
    material_check: MaterialCheck | None = None
    # z of the named effect's held-out gain over the other (ranking.Step.told_apart), and how
    # many times the data at hand would tell them apart (ranking.more_data_needed; None:
    # nothing in these recordings separates them, the separating recording is needed)
    z_apart: float | None = None
    more_data_x: float | None = None

    def to_json(self) -> dict:
        out = {"effects": self.effects, "recording": self.recording, "corr": self.corr,
               "z_apart": self.z_apart, "more_data_x": self.more_data_x}
        if self.material_check is not None:
            out["material_check"] = self.material_check.to_json()
        return out


@dataclasses.dataclass
class Identifiability:
    se: float
    identifiable: bool
    absorbed: float = 0.0  # the share of its speed error that Ke (and the effects under test) take up


@dataclasses.dataclass
class ResidualAnalysis:
    mse: float
    noise_var: float
    excess: float
    whiteness: dict    # analysis.whiteness
    correlates: list   # analysis.correlates

    def to_json(self) -> dict:
        return {"mse": self.mse, "noise_var": self.noise_var, "excess": self.excess, "whiteness": self.whiteness,
                "correlates": self.correlates}


@dataclasses.dataclass
class Hybrid:
    """The hybrid (M3 on the physics) before and after adding the missing effects."""

    rmse_before: dict
    rmse_after: dict
    iterations: int
    est_before: list   # estimates per recording
    est_after: list

    def to_json(self) -> dict:
        return {"before": self.rmse_before, "after": self.rmse_after, "iterations": self.iterations}


@dataclasses.dataclass
class Inputs:
    recs: list
    rows: list         # effects.Rows per recording
    data: ranking.Data
    ra: float
    ra_source: str
    m2: ph.PhysicsParams
    given: list        # effects already in the model under test

    @property
    def blind(self) -> bool:
        """Some rows read no temperature: a winding node runs above ambient (effects.node_path)."""
        return any(r.needs_state for r in self.rows)


@dataclasses.dataclass
class ModelFit:
    model: ph.PhysicsParams   # the model under test, as gen_weights builds it
    base: ph.PhysicsParams    # the same with Ke by least squares: the ranking's reference
    res_model: list
    res_base: list
    sigma2: float             # noise variance (noise.var_rpm2)
    mse_base: float
    noise: noise.NoiseFloor | None = None  # the floor and its parts
    ke_check: dict = dataclasses.field(default_factory=dict)  # ke_check(): eq. 20 against least squares
    channels: list = dataclasses.field(default_factory=list)  # channels.ChannelFault
    dynamics: object = None   # dynamics.Dynamics: the dynamic family from the fast recordings
    # a table that repeats no point: the out-of-fold residual variance of the model with every library effect (a
    # bound on the floor that no selection's model can raise; core.fit_model), NaN where not measured
    floor_all_rpm2: float = float("nan")
    floor_all_res: list | None = dataclasses.field(default=None, repr=False)  # that model's held-out residuals
    # a Task (interrupt.Background) giving core.all_effects_floor of these inputs, where one was started
    every: object = dataclasses.field(default=None, repr=False, compare=False)


@dataclasses.dataclass
class RaFit:
    """Ra as a nuisance parameter (ranking.RA_MISMATCH): the reading, the value the data
    support (fitted with the selection's model, prior around the reading), the prior's
    relative tolerance, how many tolerances apart, whether the selection named the mismatch,
    its bootstrap inclusion, and the effects it cannot be told apart from."""

    given_ohm: float
    supported_ohm: float
    tolerance: float
    sigmas: float
    mismatch: bool
    inclusion: float | None = None
    confounded_with: list = dataclasses.field(default_factory=list)
    # Ra as the data alone determine it (no prior; ranking.fit_ra_free): its value and 95 %
    # interval, or that these recordings do not determine it (intervals.Interval)
    data: intervals.Interval | None = None
    alongside: list = dataclasses.field(default_factory=list)  # effects fitted with it beyond the named ones
    held: bool = False  # an alternative alongside holds the reading (core.robust_ra)
    current_fault: str = ""  # a faulty current channel (channels.check): Ra cannot be concluded, no instruction
    # a structured residual the named effects leave (verdict.structured_residual): an effect missing from the library
    # can stand in for a wrong Ra, so no instruction to pass another Ra (core.physics_verdict)
    residual_left: bool = False
    # {a channel's calibration left out for the doubt on the Ra given: the Ra (ohm) within that doubt that explains the
    # rows as well without it} (core.ra_stands_in): two models that fit, one command each (cli.diagnose.next_steps)
    stand_ins: dict = dataclasses.field(default_factory=dict)

    @property
    def determined(self) -> bool:
        return self.data is None or self.data.determined

    def data_beyond(self, sigmas: float) -> bool:
        """Whether the data-alone interval (determined) lies wholly beyond sigmas tolerances of the reading."""
        d = self.data
        if d is None or not d.determined or d.lo is None:
            return False
        band = sigmas * self.tolerance * self.given_ohm
        return d.lo > self.given_ohm + band or d.hi < self.given_ohm - band

    @property
    def reading_inside(self) -> bool:
        """The data-alone value lies within the reading's own band (RA_MISMATCH_SIGMAS tolerances
        around it) and the data interval's half-width, combined in quadrature (two independent
        doubts: adding the two half-widths would call a reading 9 % off consistent with data
        that put Ra within 3.6 %): a shift within both uncertainties is no contradiction."""
        if self.data is None or not self.data.determined or self.held:
            return True
        band = ranking.RA_MISMATCH_SIGMAS * self.tolerance * self.given_ohm
        d = self.data
        if d.half_without_models is None:
            half = (d.hi - d.lo) / 2.0
            return abs(d.value - self.given_ohm) <= (band * band + half * half) ** 0.5
        # an interval reaching over several models (intervals.with_budget): the reading within the
        # same distance of the nearest of them
        reach = (band * band + d.half_without_models ** 2) ** 0.5
        return d.lo + d.half_without_models - reach <= self.given_ohm <= d.hi - d.half_without_models + reach

    @property
    def reading_inside_one_model(self) -> bool:
        """reading_inside with the data interval of the named model alone (without the spread of
        the candidate models): where it is False but reading_inside True, a model the data did not
        exclude may hold the reading (core.robust_ra asks which)."""
        if self.data is None or not self.data.determined or self.held or self.data.half_without_models is None:
            return self.reading_inside
        band = ranking.RA_MISMATCH_SIGMAS * self.tolerance * self.given_ohm
        half = self.data.half_without_models
        return abs(self.data.value - self.given_ohm) <= (band * band + half * half) ** 0.5

    @property
    def supported_at_bound(self) -> bool:
        """The fit with the prior stopped at its range (a third or three times the reading):
        supported_ohm is then that edge, not a value the data support."""
        return bool(min(abs(self.supported_ohm - self.given_ohm / 3.0),
                        abs(self.supported_ohm - 3.0 * self.given_ohm)) <= 1e-6 * self.given_ohm)

    def to_json(self) -> dict:
        return {"given_ohm": self.given_ohm, "supported_ohm": self.supported_ohm, "tolerance": self.tolerance,
                "sigmas": self.sigmas, "mismatch": bool(self.mismatch), "inclusion": self.inclusion,
                "confounded_with": list(self.confounded_with), "determined": bool(self.determined),
                # the fit with the prior stopped at its range (a third or three times the reading):
                # supported_ohm is then that edge, not a value the data support
                "supported_at_bound": self.supported_at_bound,
                "data_alone": self.data.to_json() if self.data is not None else None,
                "residual_left": bool(self.residual_left), "stand_ins": dict(self.stand_ins),
                "statement": ra_statement(self)}


@dataclasses.dataclass
class Selection:
    steps: list        # ranking.Step
    final: ph.PhysicsParams
    steps_final: ph.PhysicsParams  # the selection's final model (before the material check)
    missing: list      # effects named, in order
    ranking: list      # EffectResult
    ra_fit: RaFit | None = None
    intervals: list = dataclasses.field(default_factory=list)  # intervals.Interval of the final model's fields
    # {named effect: {rival: z}}: another effect in its place, Ra free within a wrong reading's reach,
    # explains the held-out rows as well (ranking.rivals_beside_free_ra)
    rivals: dict = dataclasses.field(default_factory=dict)
    # the bootstrap's resamples still running on the other cores (ranking.PendingBootstrap), each
    # inclusion a ranking.Pending until core.with_inclusion; None once known, or without one
    bootstrap: object | None = dataclasses.field(default=None, repr=False, compare=False)
    # {effect: coefficient} held at its material's in the final model and its intervals (core.copper_held)
    held: dict = dataclasses.field(default_factory=dict)
    # fitted models (ph.PhysicsParams) a stage found to explain the held-out rows about as well as the
    # selection's without naming their effect (core.material_check): the model part of each budget
    # reaches over their values (core.alternative_models)
    also_fit: tuple = ()
    # the node's other form weighed (core.node_form_rival): {"held_out_mse_rpm2": {"boards": .., "lagging": ..},
    # "as_well": whether it joined also_fit}; empty where no time series reads a case temperature that moves
    node_form: dict = dataclasses.field(default_factory=dict)
    # the profile over the node's time constant (core.node_profile): {"fitted_tau_s", "step", "tried": [{"tau_s", "z",
    # "as_well"}]}, each value held tried against the final model's held-out error; those as well joined also_fit
    node_profile: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class Confounding:
    groups: list       # [[effect, ...]]
    pairs: list        # ConfoundedPair
    # [{"effects": [named, other], "z": z}]: explained nearly as much as the named one alone,
    # but the recordings at hand tell the two apart (z >= Z_MIN)
    told_apart: list = dataclasses.field(default_factory=list)


@dataclasses.dataclass
class Residuals:
    after_model: ph.PhysicsParams
    res_after: list
    before: ResidualAnalysis
    after: ResidualAnalysis
    dt_s: float = 0.0  # the median sample period of the rows (a lag in rows, in seconds)


@dataclasses.dataclass
class Diagnosis:
    """The result of diagnose(); to_json() is diagnosis.json."""

    recordings: list     # dicts: name, file, rows, train_rows, glitches_removed, has_temp
    warnings: list
    ra_ohm: float
    ra_source: str
    model_effects: list
    model: ph.PhysicsParams
    missing_effects: list
    confounded: list
    separating_recordings: list  # ConfoundedPair
    not_identifiable: list       # dicts: effect, needs, se
    ranking: list                # EffectResult
    verdict: str
    noise_rpm: float
    rmse_before: dict
    rmse_after: dict
    after_model: ph.PhysicsParams
    residual_before: ResidualAnalysis
    residual_after: ResidualAnalysis
    steps: list                  # RankingStep
    thresholds: dict
    hybrid: Hybrid | None
    runtime_s: float
    leave_one_out: dict | None = None  # see leave_one_out()
    # the winding node of the model under test and of it with the missing effects, each
    # field against its declared ranges (effects.node_plausibility; schema.NODE); in the
    # JSON at the top level and under each thermal ranking row
    thermal_node: dict = dataclasses.field(default_factory=dict)
    ra_fit: RaFit | None = None  # Ra as a nuisance parameter (ranking.RA_MISMATCH)
    told_apart: list = dataclasses.field(default_factory=list)  # Confounding.told_apart
    # the channel offsets read at rest (effects.rest_offsets): {effect: {value, se, rows}}
    rest_offsets: dict = dataclasses.field(default_factory=dict)
    # what the intervals' sensors' part takes of the channels' calibration (core.sensors_assumed)
    sensors: dict = dataclasses.field(default_factory=dict)
    # every quantity the model with the missing effects fitted (Ke, coefficients, shapes, the
    # winding node), with its interval from the data or "not determined" (intervals.Interval)
    intervals: list = dataclasses.field(default_factory=list)
    noise_floor: dict = dataclasses.field(default_factory=dict)  # noise.NoiseFloor.to_json()
    # each recording (a table's operating groups) against the model identified without it
    # (consistency(): {"units": [Unit.to_json()], "without": the verdict without the odd one})
    consistency: dict = dataclasses.field(default_factory=dict)
    ke_check: dict = dataclasses.field(default_factory=dict)  # ke_check()
    channels: list = dataclasses.field(default_factory=list)  # channels.ChannelFault.to_json()
    dynamics: dict = dataclasses.field(default_factory=dict)  # dynamics.Dynamics.to_json()
    # {named effect: coefficient} held at its material's where hpddo train would fit it free (Selection.held)
    held: dict = dataclasses.field(default_factory=dict)
    # for the report's figures (not in the JSON)
    rows: list = dataclasses.field(repr=False, default_factory=list)
    est_before: list = dataclasses.field(repr=False, default_factory=list)
    est_after: list = dataclasses.field(repr=False, default_factory=list)
    res_before: list = dataclasses.field(repr=False, default_factory=list)
    res_after: list = dataclasses.field(repr=False, default_factory=list)

    def to_json(self) -> dict:
        out = {
            "recordings": self.recordings,
            **reference_json(self.recordings),
            "warnings": self.warnings,
            "ra_ohm": self.ra_ohm, "ra_source": self.ra_source,
            "ra_fit": self.ra_fit.to_json() if self.ra_fit is not None else None,
            "model_effects": self.model_effects,
            "model": dataclasses.asdict(self.model),
            "missing_effects": self.missing_effects,
            **({"held_effects": self.held} if self.held else {}),  # absent where none: the bytes of before
            "confounded": self.confounded,
            "separating_recordings": [s.to_json() for s in self.separating_recordings],
            "told_apart": self.told_apart,
            "rest_offsets": self.rest_offsets,
            "sensors": self.sensors,
            "intervals": [iv.to_json() for iv in self.intervals],
            "not_identifiable": self.not_identifiable,
            "ranking": [e.to_json() for e in self.ranking],
            "verdict": self.verdict,
            "noise_rpm": self.noise_rpm,
            "noise_floor": self.noise_floor,
            "consistency": self.consistency,
            "ke_check": self.ke_check,
            "channels": self.channels,
            "dynamics": self.dynamics,
            "rmse_rpm": {"before": self.rmse_before, "after": self.rmse_after},
            "after_model": dataclasses.asdict(self.after_model),
            "thermal_node": self.thermal_node,
            "residual_before": self.residual_before.to_json(),
            "residual_after": self.residual_after.to_json(),
            "steps": [s.to_json() for s in self.steps],
            "thresholds": self.thresholds,
        }
        if self.hybrid is not None:
            out["rmse_rpm_hybrid"] = self.hybrid.to_json()
        if self.leave_one_out is not None:
            out["leave_one_out"] = self.leave_one_out
        out["runtime_s"] = self.runtime_s
        return out

    def plot(self) -> dict:
        """What the report's figures need besides the JSON."""
        hyb = {} if self.hybrid is None else {"before": self.hybrid.est_before, "after": self.hybrid.est_after}
        return {"rows": self.rows, "est_before": self.est_before, "est_after": self.est_after, "hybrid": hyb,
                "res_before": self.res_before, "res_after": self.res_after}


def _alone(ra: RaFit) -> str:
    """Ra from the data alone, in words ("" without it)."""
    d = ra.data
    if d is None:
        return ""
    with_ = "Ke, the named effects and " + " and ".join(ra.alongside) if ra.alongside else "Ke and the named effects"
    return f"with {with_} fitted alongside, the data alone put Ra at {d.value:.3g} ohm ({100 * intervals.LEVEL:.0f} % interval {d.lo:.3g}..{d.hi:.3g})"


def _with(ra: RaFit) -> str:
    return f" with {' and '.join(ra.alongside)} fitted alongside" if ra.alongside else ""


def ra_statement(ra: RaFit | None) -> str:
    """What the recordings say of Ra, one clause for the summary: never a value they do not
    determine."""
    if ra is None:
        return ""
    if not ra.determined:
        return (f"{ra.given_ohm:.3g} ohm given; Ra is not determined by these recordings{_with(ra)} ({ra.data.why}), so "
                f"whether the reading is right cannot be told; what would determine it: {ra.data.needs}")
    head = f"{ra.given_ohm:.3g} ohm given; " + (_alone(ra) + "; " if ra.data is not None else "")
    if ra.mismatch:
        # where a model with the reading and an effect explains the rows as well (confounded_with), the data-alone
        # interval reaches over the reading (core.reading_a_rival) and the mismatch holds only without that effect
        unless = f" unless {' or '.join(ra.confounded_with)} is at work (not told apart)" if ra.confounded_with else ""
        return head + (f"with the reading's {100 * ra.tolerance:.0f} % tolerance as a prior {ra.supported_ohm:.3g} "
                       f"ohm ({ra.sigmas:+.1f} x the tolerance): a mismatch{unless}")
    if ra.confounded_with:
        return head + "not told apart from " + " or ".join(ra.confounded_with)
    if ra.reading_inside:
        return head + f"consistent with the reading and its {100 * ra.tolerance:.0f} % tolerance"
    if ra.current_fault:  # (as the verdict says: nothing on Ra concluded from a faulty current channel)
        return head + (f"the reading lies outside it, but {ra.current_fault} (Channel health) and Ra rests on it: "
                       "whether the reading is right is not concluded from these recordings")
    return head + "the reading lies outside it, but moving Ra does not lower the held-out error enough to name a mismatch"


def reference_json(recordings: list) -> dict:
    """{"reference": the pooled record} where rpm_ref came from the ripple (hpddo.ripple.reference)."""
    from ..ripple import reference
    pooled = reference.pooled({r["name"]: r.get("reference") for r in recordings})
    return {} if pooled is None else {"reference": pooled}
