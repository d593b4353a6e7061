"""The diagnosis: model against measurements, residual analysis, ranking of the missing
effects, verdict, and the error before and after adding them (physics and hybrid).

diagnose() strings the stages together, each a function of typed values:

  load            the recordings, their rows, Ra and the plain model M2      -> Inputs
  fit_model       the model under test, the least-squares reference, noise   -> ModelFit
  identifiability which effects these recordings can show at all             -> {effect: Identifiability}
  select          forward selection, bootstrap, the ranking table            -> Selection
  confounding     alternatives that explained nearly as much                 -> Confounding
  material_check  a material constant as a test of confounding               -> (Selection, Confounding)
  residuals       residual analysis before and after adding the effects      -> Residuals
  verdict         the verdict text                                           -> str
  hybrid          the hybrid's RMSE before and after (optional)              -> Hybrid | None

The result is a Diagnosis; Diagnosis.to_json() is diagnosis.json.
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from ..logs import dataset
from ..model import identify
from .. import schema
from ..logs.errors import InputError
from ..model import effects as fx
from ..model import physics as ph
from ..model.train import TrainConfig, TrainingError, hybrid_rpm, train_residual
from . import analysis, ranking

MIN_HELD_OUT_ROWS = 8  # fewer held-out labelled rows cannot rank anything
HYBRID_ITER = 150  # training epochs of the hybrid in the diagnosis (hpddo train: 2000)
# The material reading (e.g. copper plus magnets) is taken when its held-out mean squared
# error is at most this many noise variances above the freely fitted one's.
MATERIAL_SLACK = 0.5


@dataclasses.dataclass
class Options:
    effects: tuple = ()          # effects already in the model under test
    ra_ohm: float | None = None
    bootstrap: int = ranking.BOOTSTRAP
    hybrid: bool = True
    hybrid_iter: int = HYBRID_ITER
    seed: int = 1
    glitch_filter: bool = True
    leave_one_out: bool = False  # also score the physics before/after on each recording, fitted on the others


# ---------------------------------------------------------------------------------------
# Typed parts of the result


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
    for sh in eff.shapes:  # a form at the edge of those allowed (but the base form): not fixed by the data
        v, (lo, hi) = float(getattr(p, sh.field)), sh.bounds
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


# ---------------------------------------------------------------------------------------
# Stage values


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
    sigma2: float             # noise variance
    mse_base: float


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

    def to_json(self) -> dict:
        return {"given_ohm": self.given_ohm, "supported_ohm": self.supported_ohm, "tolerance": self.tolerance,
                "sigmas": self.sigmas, "mismatch": bool(self.mismatch), "inclusion": self.inclusion,
                "confounded_with": list(self.confounded_with)}


@dataclasses.dataclass
class Selection:
    steps: list        # ranking.Step
    final: ph.PhysicsParams
    steps_final: ph.PhysicsParams  # the selection's final model (before the material check)
    missing: list      # effects named, in order
    ranking: list      # EffectResult
    ra_fit: RaFit | None = None


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
    # for the report's figures (not in the JSON)
    rows: list = dataclasses.field(repr=False, default_factory=list)
    est_before: list = dataclasses.field(repr=False, default_factory=list)
    est_after: list = dataclasses.field(repr=False, default_factory=list)
    res_before: list = dataclasses.field(repr=False, default_factory=list)
    res_after: list = dataclasses.field(repr=False, default_factory=list)

    def to_json(self) -> dict:
        out = {
            "recordings": self.recordings,
            "warnings": self.warnings,
            "ra_ohm": self.ra_ohm, "ra_source": self.ra_source,
            "ra_fit": self.ra_fit.to_json() if self.ra_fit is not None else None,
            "model_effects": self.model_effects,
            "model": dataclasses.asdict(self.model),
            "missing_effects": self.missing_effects,
            "confounded": self.confounded,
            "separating_recordings": [s.to_json() for s in self.separating_recordings],
            "told_apart": self.told_apart,
            "rest_offsets": self.rest_offsets,
            "not_identifiable": self.not_identifiable,
            "ranking": [e.to_json() for e in self.ranking],
            "verdict": self.verdict,
            "noise_rpm": self.noise_rpm,
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


# ---------------------------------------------------------------------------------------
# Stages


def load(paths, opt: Options) -> Inputs:
    """The recordings, their rows, Ra and M2; refuses recordings with too few held-out rows."""
    recs = dataset.load_recordings(paths, glitch_filter=opt.glitch_filter)
    ra, ra_source = identify.ra_from_logs(recs, opt.ra_ohm)
    m2 = identify.m2_params(recs, ra)
    given = list(fx.check_names(opt.effects))
    data = ranking.make_data([fx.rows_of(r) for r in recs])
    rows = data.rows  # under cross-validation (small data) every labelled row is train and test
    held_out = sum(int(r.test.sum()) for r in rows)
    if held_out < MIN_HELD_OUT_ROWS:
        raise InputError(f"only {held_out} held-out rows with rpm_ref > {fx.MIN_RPM} RPM in "
                         f"{', '.join(str(r.source) for r in recs)}: the diagnosis scores every effect on rows "
                         f"not used to fit it and needs at least {MIN_HELD_OUT_ROWS}; give longer recordings")
    return Inputs(recs=recs, rows=rows, data=data, ra=ra, ra_source=ra_source, m2=m2, given=given)


def fit_model(inp: Inputs) -> ModelFit:
    """The model under test, its least-squares reference and the noise floor."""
    d = inp.data
    model = fx.identify(inp.recs, inp.m2, inp.given) if inp.given else inp.m2
    res_model = ranking.residuals(d, model)
    base, res_base = ranking.scored(d, lambda rows, st: fx.fit(rows, inp.m2, inp.given, start=st))
    sigma2 = ranking.noise_var(d, res_base)
    return ModelFit(model=model, base=base, res_model=res_model, res_base=res_base, sigma2=sigma2,
                    mse_base=ranking.held_out_mse(d, res_base))


def identifiability(inp: Inputs, mf: ModelFit) -> dict:
    """{effect: Identifiability} of every effect not in the model under test."""
    out = {}
    for c in fx.NAMES:
        if c not in inp.given:
            r = ranking.identifiability(inp.data, mf.base, c, mf.sigma2, inp.given)
            out[c] = Identifiability(se=r["se"], identifiable=r["identifiable"])
    return out


def select(inp: Inputs, mf: ModelFit, ident: dict, opt: Options) -> Selection:
    """Forward selection on the identifiable effects, the bootstrap's inclusion frequencies,
    and the ranking table: the named effects, the other candidates' gains on the final
    model, the effects these recordings cannot show."""
    d, rows, m2, given, sigma2 = inp.data, inp.rows, inp.m2, inp.given, mf.sigma2
    RA = ranking.RA_MISMATCH
    candidates = [c for c in ident if ident[c].identifiable] + [RA]
    steps, final = ranking.forward_select(d, m2, given, candidates, sigma2)
    chosen = [s.name for s in steps if s.name]
    missing = [c for c in chosen if c != RA]
    boot = ranking.bootstrap(d, m2, given, candidates, sigma2, final, opt.bootstrap, seed=opt.seed)
    # An effect named at a step where a wrong Ra passed every test too is told apart from it
    # only when its held-out gain over the wrong-Ra model is Z_MIN standard errors or more;
    # otherwise neither is named (RaFit.confounded_with).
    ra_confounded = [st.name for st in steps if st.name in missing and st.ra_z is not None
                     and st.ra_z < ranking.Z_MIN]
    if ra_confounded:
        chosen = [c for c in chosen if c not in ra_confounded]
        missing = [c for c in missing if c not in ra_confounded]
        final = ranking.fit_names(rows, m2, given + [c for c in chosen if c != RA] + [RA], sigma2, start=final)
        if abs(ranking.ra_sigmas(m2, final.ra_ohm)) > ranking.RA_MISMATCH_SIGMAS and RA not in chosen:
            chosen.append(RA)
        elif RA not in chosen:
            final = fx.fit(rows, m2, given + chosen, start=final)
    ra_fit = _ra_fit(inp, final if RA in chosen else None, given + chosen, sigma2, boot.get(RA))
    # the effects a wrong Ra cannot be told from: not named at the wrong Ra's step though they
    # explained nearly as much (as confounding() groups effects), or named but not told apart
    for st in steps:
        if st.name == RA:
            ra_fit.confounded_with += [a for a, g, z, phy in st.alternatives if a != RA and phy
                                       and z >= ranking.Z_MIN and g >= ranking.CONFOUND_GAIN * st.gain]
    ra_fit.confounded_with += ra_confounded
    # ... and what those explained no better than (the alternatives of their step that the
    # recordings did not tell apart from them): one of these is the cause, the data cannot say which
    for st in steps:
        if st.name in ra_confounded:
            ra_fit.confounded_with += [a for a, z in st.told_apart.items()
                                       if a != RA and z < ranking.Z_MIN and a not in ra_fit.confounded_with]

    # single-effect gains on the base model (the first step's trial) for the ranking table
    first = {a[0]: a for a in steps[0].alternatives} if steps else {}
    table = [EffectResult(s.name, "named", score=_score(s.gain, mf.mse_base), gain_rpm2=s.gain, z=s.z,
                          inclusion=boot.get(s.name), **_described(s.name, final, inp.blind))
             for s in steps if s.name in missing]
    res_final = None
    for c in candidates:
        if c in chosen or c == RA:
            continue
        try:
            pc, rc = ranking.scored_names(d, m2, given + chosen + [c], sigma2, start=final)
        except Exception:
            continue
        if res_final is None:  # the final model's held-out residuals (refitted per fold under cross-validation)
            res_final = ranking.held_out_residuals(
                d, final, lambda rs, st: ranking.fit_names(rs, m2, given + chosen, sigma2, start=st))
        g, z = ranking.gain_z(d, res_final, rc, sigma2)
        single = first.get(c)
        table.append(EffectResult(c, "candidate", score=_score(g, mf.mse_base), gain_rpm2=g, z=z,
                                  inclusion=boot.get(c),
                                  physical=ranking._physical(c, getattr(pc, fx.LIBRARY[c].field)),
                                  alone_gain_rpm2=single[1] if single else None, **_described(c, pc, inp.blind)))
    for c in fx.NAMES:
        if c in given or c in candidates:
            continue
        table.append(EffectResult(c, "unseen", score=0.0, params={}, se=ident[c].se,
                                  meaning=fx.LIBRARY[c].meaning,
                                  plausibility="not identifiable on these recordings",
                                  needs=fx.LIBRARY[c].excited_by))
    return Selection(steps=steps, final=final, steps_final=final, missing=missing, ranking=table, ra_fit=ra_fit)


def _ra_fit(inp: Inputs, final: ph.PhysicsParams | None, names, sigma2: float, inclusion) -> RaFit:
    """Ra as the data support it. final: the selection's model when it named RA_MISMATCH;
    otherwise the selection's model is refitted once with Ra moving (prior around the
    reading) to say what the data support."""
    named = final is not None
    if final is None:
        try:
            final = ranking.fit_names(inp.rows, inp.m2, list(names) + [ranking.RA_MISMATCH], sigma2)
        except Exception:
            final = inp.m2
    given = inp.m2.ra_ohm
    return RaFit(given_ohm=given, supported_ohm=float(final.ra_ohm), tolerance=ranking.RA_TOLERANCE,
                 sigmas=float(ranking.ra_sigmas(inp.m2, final.ra_ohm)), mismatch=named, inclusion=inclusion)


def confounding(inp: Inputs, mf: ModelFit, sel: Selection) -> Confounding:
    """Alternatives that explained nearly as much at the step an effect was named."""
    groups, pairs, apart = [], [], []
    # an offset read at rest (effects.rest_offsets) is measured by those rows, not by the fit:
    # whatever else explains the same speed error, the rows at rest tell it apart (z: the
    # reading's mean over its standard error)
    rest = {n: abs(v) / se for n, (v, se, _) in fx.rest_offsets(inp.rows).items() if se > 0}
    for s in sel.steps:
        if not s.name or (s.name not in sel.missing and s.name != ranking.RA_MISMATCH):
            continue  # nothing named, or named but not told apart from a wrong Ra (select)
        group = [s.name]
        for name, g, z, physical in s.alternatives:
            if name != s.name and physical and z >= ranking.Z_MIN and g >= ranking.CONFOUND_GAIN * s.gain:
                za = s.told_apart.get(name)
                if rest.get(s.name, 0.0) >= ranking.Z_MIN:
                    za = max(za or 0.0, rest[s.name])
                if za is not None and za >= ranking.Z_MIN and ranking.RA_MISMATCH not in (s.name, name):
                    apart.append({"effects": [s.name, name], "z": float(za)})
                    continue  # the recordings at hand separate them
                group.append(name)
        if s.name == ranking.RA_MISMATCH:  # said in RaFit.confounded_with (select)
            continue
        # a wrong Ra as the alternative of an effect is decided by select (named beyond Ra)
        group = [g for g in group if g != ranking.RA_MISMATCH]
        if len(group) > 1:
            groups.append(group)
            for other in group[1:]:
                za = s.told_apart.get(other)
                pairs.append(ConfoundedPair([s.name, other], ranking.separator(s.name, other),
                                            ranking.partial_corr(inp.data, mf.base, s.name, other, inp.given),
                                            z_apart=za, more_data_x=ranking.more_data_needed(za)))
    return Confounding(groups=groups, pairs=pairs, told_apart=apart)


def material_check(inp: Inputs, mf: ModelFit, sel: Selection, conf: Confounding) -> tuple[Selection, Confounding]:
    """A material constant as a test of confounding: an effect whose coefficient is a
    material constant (schema: material, material_band; thermal_ra: copper's) named with a
    value far from it means the effect it shares its work with (shares_work_with:
    magnet_thermal) took part of it. If the material's value plus the other effect explains
    the held-out rows as well, the data cannot tell the two apart, and the physical reading
    (copper + magnets) is the one named."""
    d, rows, m2, given, sigma2 = inp.data, inp.rows, inp.m2, inp.given, mf.sigma2
    missing, final, table = list(sel.missing), sel.final, list(sel.ranking)
    groups, pairs = list(conf.groups), list(conf.pairs)
    for name in list(missing):
        eff = fx.LIBRARY[name]
        other = eff.shares_work_with
        if not other or other in given + missing or eff.is_material(getattr(final, eff.field)):
            continue
        oeff = fx.LIBRARY[other]
        try:
            alt, res_alt = ranking.scored(d, lambda rs, st: fx.fit(rs, m2, given + missing + [other], start=st))
        except Exception:
            continue
        res_sel = ranking.held_out_residuals(d, final, lambda rs, st: fx.fit(rs, m2, given + missing, start=st))
        mse_sel = ranking.held_out_mse(d, res_sel)
        mse_alt = ranking.held_out_mse(d, res_alt)
        if not (oeff.plausibility(getattr(alt, oeff.field))[0] and mse_alt <= mse_sel + MATERIAL_SLACK * sigma2):
            continue
        missing.append(other)
        final = alt
        table = [e.at(final, inp.blind) if e.named else e for e in table if e.effect != other]
        # its share: what it removes once the material's coefficient is held
        res_held = ranking.scored(d, lambda rs, st: fx.fit(rs, m2, given + missing[:-1], hold={name: eff.material},
                                                           start=st))[1]
        g, z = ranking.gain_z(d, res_held, res_alt, sigma2)
        table.insert(len([e for e in table if e.named]),
                     EffectResult(other, "named", score=_score(g, mf.mse_base), gain_rpm2=g, z=z, inclusion=None,
                                  note=f"named with {name} held at {eff.material_name}'s coefficient, "
                                       "which the free fit missed; not bootstrapped",
                                  **_described(other, final, inp.blind)))
        groups.append([name, other])
        pairs.append(ConfoundedPair([name, other], ranking.separator(name, other),
                                    ranking.partial_corr(d, mf.base, name, other, given),
                                    MaterialCheck(name, other, getattr(sel.steps_final, eff.field), mse_sel, mse_alt)))
    return (dataclasses.replace(sel, final=final, missing=missing, ranking=table),
            Confounding(groups=groups, pairs=pairs, told_apart=conf.told_apart))


# the inputs the residual is cross-correlated with: (name, Rows attribute)
RESIDUAL_INPUTS = (("V", "v"), ("I", "i"), ("duty", "duty"), ("temp_C", "temp"), ("speed", "ref"),
                   ("dI/dt", "di_dt"))


def analyse(inp: Inputs, res, sigma2: float) -> ResidualAnalysis:
    """Whiteness and correlates of the held-out residual res (contiguous runs)."""
    rows = inp.rows
    parts = analysis.parts(rows, res)
    inputs = {}
    for key, attr in RESIDUAL_INPUTS:
        pieces = analysis.parts(rows, res, [getattr(r, attr) for r in rows])
        if pieces and all(np.all(np.isfinite(a)) for a in pieces):
            inputs[key] = pieces
    w = analysis.whiteness(parts)
    corr = analysis.correlates(parts, inputs)
    mse = ranking.held_out_mse(inp.data, res)
    return ResidualAnalysis(mse=mse, noise_var=sigma2, excess=max(0.0, mse - sigma2), whiteness=w, correlates=corr)


def residuals(inp: Inputs, mf: ModelFit, sel: Selection) -> Residuals:
    """Residual analysis of the model under test and of it with the missing effects."""
    changed = bool(sel.missing) or (sel.ra_fit is not None and sel.ra_fit.mismatch)
    after_model = fx.identify(inp.recs, inp.m2, inp.given + sel.missing) if changed else mf.model
    res_after = ranking.residuals(inp.data, after_model)
    return Residuals(after_model=after_model, res_after=res_after, before=analyse(inp, mf.res_model, mf.sigma2),
                     after=analyse(inp, res_after, mf.sigma2))


def ra_verdict(ra: RaFit | None) -> str:
    """The verdict's sentence on Ra; "" when the reading fits."""
    if ra is None or (not ra.mismatch and not ra.confounded_with):
        return ""
    rel = ra.supported_ohm / ra.given_ohm - 1.0
    if not ra.mismatch:
        return (f"An error proportional to the current remains that a wrong Ra (the data support "
                f"{ra.supported_ohm:.3g} ohm against the {ra.given_ohm:.3g} ohm given, within the reading's "
                f"{ra.tolerance:.0%} tolerance) explains as well as {' or '.join(ra.confounded_with)}, so "
                f"neither is named; to separate them: {ranking.RA_SEPARATOR}.")
    text = (f"The Ra you gave ({ra.given_ohm:.3g} ohm) does not fit these recordings: they support "
            f"{ra.supported_ohm:.3g} ohm ({rel:+.1%}, {abs(ra.sigmas):.1f}x the reading's "
            f"{ra.tolerance:.0%} tolerance), an error proportional to the current; the effects were "
            "looked for with Ra at that value.")
    if ra.confounded_with:
        text += (f" These recordings cannot tell a wrong Ra from {' or '.join(ra.confounded_with)}, so "
                 f"{'neither' if len(ra.confounded_with) == 1 else 'none of them'} is named as an effect; "
                 f"to separate them: {ranking.RA_SEPARATOR}.")
    text += (f" hpddo train still uses the Ra given: re-measure Ra, or pass --ra-ohm "
             f"{ra.supported_ohm:.3g} if you trust these recordings.")
    return text


def verdict(sel: Selection, conf: Confounding, resid: Residuals, sigma2: float) -> str:
    ra = ra_verdict(sel.ra_fit)
    text = _verdict(sel, conf, resid, sigma2)
    return f"{ra} {text}" if ra else text


def _verdict(sel: Selection, conf: Confounding, resid: Residuals, sigma2: float) -> str:
    after = resid.after
    structured_left = (after.excess > 0.5 * sigma2) and not after.whiteness["white"]
    if not sel.missing:
        if structured_left:
            return ("No library effect explains the residual, but it is not noise: it is "
                    f"{after.excess / max(sigma2, 1e-12):.1f}x the noise variance above the noise floor "
                    "and not white. Its strongest correlates: " +
                    ", ".join(f"{c['input']} (r = {c['peak']:+.2f} at lag {c['peak_lag']})"
                              for c in after.correlates[:3] if c["significant"]) + ".")
        if sel.ra_fit is not None and sel.ra_fit.mismatch:
            return "No effect missing once Ra is corrected: the residual is then consistent with measurement noise."
        return "Nothing missing: the residual is consistent with measurement noise."
    text = "Missing: " + ", ".join(f"{e.effect} ({e.shown})" for e in sel.ranking if e.named) + "."
    if conf.groups:
        text += " " + " ".join(_pair_sentence(s) for s in conf.pairs if ranking.RA_MISMATCH not in s.effects)
    if conf.told_apart:
        text += " " + " ".join(
            f"{a['effects'][1]} explains much of what {a['effects'][0]} does, but these recordings tell "
            f"the two apart (z = {a['z']:.1f})." for a in conf.told_apart)
    if structured_left:
        text += (" A structured residual remains that no library effect explains "
                 f"({after.excess / max(sigma2, 1e-12):.1f}x the noise variance); strongest correlates: " +
                 ", ".join(f"{c['input']} (r = {c['peak']:+.2f})" for c in after.correlates[:3]
                           if c["significant"]) + ".")
    return text


def _pair_sentence(s: ConfoundedPair) -> str:
    text = (f"{' and '.join(s.effects)} cannot be told apart on these recordings; "
            f"a recording that would separate them: {s.recording}.")
    if s.more_data_x is not None and s.more_data_x > 1.0:
        text += (f" These recordings hold a little of it (z = {s.z_apart:.1f}): about {s.more_data_x:.0f} times "
                 "as much of it would tell them apart.")
    return text


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
    the observer's clamp, envelope fallback and novelty gate (train.hybrid_rpm)."""
    res = train_residual(recs, p, TrainConfig(hidden=(16, 8), max_iter=cfg_iter, seed=seed, progress=False))
    return [hybrid_rpm(res, r, p) for r in recs]


def hybrid(inp: Inputs, model: ph.PhysicsParams, after_model: ph.PhysicsParams, changed: bool,
           opt: Options) -> tuple[Hybrid | None, list]:
    """The hybrid on the model under test and on it with the missing effects (the same
    network when nothing changed): (Hybrid, warnings); None when it cannot be trained."""
    try:
        hb = _hybrid(inp.recs, model, opt.hybrid_iter, opt.seed)
    except TrainingError as exc:  # too few rows for a network: the physics verdict stands alone
        return None, [f"hybrid before/after not computed: {exc}"]
    ha = _hybrid(inp.recs, after_model, opt.hybrid_iter, opt.seed) if changed else hb
    rows = inp.rows
    return Hybrid(rmse_before=_rmse_by_condition(rows, [r.ref - h for r, h in zip(rows, hb)]),
                  rmse_after=_rmse_by_condition(rows, [r.ref - h for r, h in zip(rows, ha)]),
                  iterations=opt.hybrid_iter, est_before=hb, est_after=ha), []


# ---------------------------------------------------------------------------------------


def leave_one_out(inp: Inputs, missing: list) -> dict:
    """Whether the named effects hold on a recording the fit never saw: for each recording,
    Ke and the effect coefficients fitted on the other recordings only (the model under
    test, and it with the missing effects), scored on every row of the one left out.
    {"recordings": {name: {"before", "after"}}, "average": {"before", "after"}}, RMSE in RPM.
    The physics only: the hybrid's cross-recording figure is hpddo train --leave-one-out."""
    from ..evaluation.metrics import figure, rmse
    from ..model.train import physics_rpm

    scores = {}
    for k, held in enumerate(inp.recs):
        others = inp.recs[:k] + inp.recs[k + 1:]
        m2 = identify.m2_params(others, inp.ra)
        before = fx.identify(others, m2, inp.given) if inp.given else m2
        after = fx.identify(others, m2, list(inp.given) + list(missing)) if missing else before
        ref = held.df["rpm_ref"].to_numpy(float) if "rpm_ref" in held.df else np.full(held.n, np.nan)
        scores[held.name] = {"before": figure(rmse(physics_rpm(held, before) - ref)),
                             "after": figure(rmse(physics_rpm(held, after) - ref))}
    avg = {w: figure(float(np.mean([s[w] for s in scores.values()]))) for w in ("before", "after")}
    return {"recordings": scores, "average": avg}


def diagnose(paths, opt: Options) -> Diagnosis:
    t0 = time.perf_counter()
    inp = load(paths, opt)
    mf = fit_model(inp)
    ident = identifiability(inp, mf)
    sel = select(inp, mf, ident, opt)
    conf = confounding(inp, mf, sel)
    if sel.ra_fit.mismatch:  # from here on, Ra is held at the value the data support
        inp = dataclasses.replace(inp, m2=dataclasses.replace(inp.m2, ra_ohm=sel.ra_fit.supported_ohm))
    named = list(sel.missing)
    sel, conf = material_check(inp, mf, sel, conf)
    if not sel.ra_fit.mismatch and sel.missing != named:
        # the Ra the data support with the effects the material check added
        sup = _ra_fit(inp, None, inp.given + sel.missing, mf.sigma2, sel.ra_fit.inclusion)
        sel = dataclasses.replace(sel, ra_fit=dataclasses.replace(sel.ra_fit, supported_ohm=sup.supported_ohm,
                                                                  sigmas=sup.sigmas))
    resid = residuals(inp, mf, sel)
    text = verdict(sel, conf, resid, mf.sigma2)
    changed = bool(sel.missing) or sel.ra_fit.mismatch
    hyb, hyb_warnings = hybrid(inp, mf.model, resid.after_model, changed, opt) if opt.hybrid else (None, [])
    d = _result(inp, mf, ident, sel, conf, resid, text, hyb, hyb_warnings, opt, t0)
    if opt.leave_one_out:
        if len(inp.recs) < 2:
            raise InputError("leave-one-out needs at least two recordings (one to leave out, one to fit on)")
        d.leave_one_out = leave_one_out(inp, sel.missing)
        d.runtime_s = time.perf_counter() - t0
    return d


def _result(inp, mf, ident, sel, conf, resid, text, hyb, hyb_warnings, opt, t0) -> Diagnosis:
    rows = inp.rows
    unseen = [c for c, i in ident.items() if not i.identifiable]
    return Diagnosis(
        recordings=[{"name": r.name, "file": str(r.source), "rows": r.n, "train_rows": r.n_train,
                     "glitches_removed": len(r.removed), "has_temp": r.has_temp()} for r in inp.recs],
        warnings=[w for r in inp.recs for w in r.warnings] + hyb_warnings,
        ra_ohm=inp.ra, ra_source=inp.ra_source, ra_fit=sel.ra_fit, model_effects=inp.given, model=mf.model,
        missing_effects=sel.missing, confounded=conf.groups, separating_recordings=conf.pairs,
        told_apart=conf.told_apart,
        rest_offsets={k: {"value": v, "se": se, "rows": n} for k, (v, se, n) in fx.rest_offsets(rows).items()},
        not_identifiable=[{"effect": c, "needs": fx.LIBRARY[c].excited_by, "se": ident[c].se} for c in unseen],
        ranking=sel.ranking, verdict=text, noise_rpm=float(np.sqrt(mf.sigma2)),
        rmse_before=_rmse_by_condition(rows, mf.res_model), rmse_after=_rmse_by_condition(rows, resid.res_after),
        after_model=resid.after_model, residual_before=resid.before, residual_after=resid.after,
        steps=[RankingStep.of(s) for s in sel.steps],
        thresholds={"z_min": ranking.Z_MIN, "rel_min": ranking.REL_MIN, "excess_min": ranking.EXCESS_MIN,
                    "score_min": ranking.SCORE_MIN,
                    "confound_gain": ranking.CONFOUND_GAIN, "bootstrap": opt.bootstrap,
                    "held_out": inp.data.scheme, "bootstrap_blocks": ranking.n_train_blocks(inp.data)},
        hybrid=hyb, runtime_s=time.perf_counter() - t0,
        thermal_node={"path": fx.node_path(inp.blind), "model": fx.node_plausibility(mf.model, inp.blind),
                      "after_model": fx.node_plausibility(resid.after_model, inp.blind)},
        rows=rows, est_before=[r.ref - e for r, e in zip(rows, mf.res_model)],
        est_after=[r.ref - e for r, e in zip(rows, resid.res_after)],
        res_before=mf.res_model, res_after=resid.res_after)
