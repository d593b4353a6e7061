"""Bench parameters, the eight switchable effects, and the presets.

Units are in the names (``ra_ohm``, ``ke_vs_per_rad``, ``la_H``, ``j_kgm2``...).
Mechanical quantities are lumped at the *output shaft* (after the 1:4.4 gearbox),
which is the shaft the encoder speed ``rpm_ref`` refers to and the shaft the paper's
lumped constant K_e,M2 = 0.406 V s/rad refers to. Sources are given per value:
``paper`` (hpddo-pmdc, sections 3.4-3.6, 4.1-4.4, Appendix A) or ``assumed``
(with the reasoning in docs/twin.md).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import bench as _bench
from .. import schema

_HW = _bench.HARDWARE

GENERATOR_VERSION = "hpddo-twin 0.1.0"


@dataclasses.dataclass(frozen=True)
class Effect:
    """One switchable physical effect: its magnitude in its shown unit (0 = off).

    The name, the shown unit and its scale to SI come from the effect's declaration in
    hpddo/schema.py (the model's effects and the bench-only ripple); the magnitudes and
    the texts below are the bench's own."""

    name: str
    unit: str  # shown unit of the magnitude (schema show_unit)
    default: float  # magnitude in the default preset
    typical: tuple  # (low, high) typical range of the magnitude, shown unit
    physics: str
    m2: str  # what it does to the M2 estimate (with the true K_e)

    @property
    def si_unit(self) -> str:
        return schema.effect(self.name).unit

    def to_si(self, magnitude: float) -> float:
        """A magnitude in the shown unit as the SI value (the PhysicsParams field's unit)."""
        return schema.effect(self.name).to_si(magnitude)


def effects_md() -> str:
    """The effects table of docs/twin.md: name, shown unit (the schema's), default
    magnitude, typical range, physics and what it does to M2, from EFFECTS."""
    rows = ["| name | unit | default | typical | physics | M2 error |", "|---|---|---|---|---|---|"]
    for e in EFFECTS.values():
        lo, hi = e.typical
        rows.append(f"| `{e.name}` | {e.unit} | {e.default:g} | {lo:g}..{hi:g} | {schema.md_cell(e.physics)} | "
                    f"{schema.md_cell(e.m2)} |")
    return "\n".join(rows) + "\n"


def _effect(name: str, default: float, typical: tuple, physics: str, m2: str) -> Effect:
    return Effect(name, schema.effect(name).show_unit, default, typical, physics, m2)


EFFECTS = {
    e.name: e
    for e in [
        _effect(
            "thermal_ra", 0.393, (0.38, 0.40),
            "armature (copper) resistance rises with winding temperature: "
            "Ra(T) = Ra_ref (1 + a (T_w - T_ref)), copper a = 0.393 %/K",
            "M2 uses the cold 4.50 ohm, so V - I Ra keeps I (Ra(T) - 4.50): "
            "speed overestimated by I dRa / Ke, growing as the winding heats",
        ),
        _effect(
            "magnet_thermal", -0.2, (-0.20, -0.12),
            "ferrite magnet flux falls with magnet (case) temperature: "
            "Ke(T) = Ke_ref (1 + b (T_c - T_ref)), ferrite b about -0.2 %/K (NdFeB -0.12)",
            "back-EMF per rad/s shrinks as the case warms: speed underestimated by "
            "|b| dT n, growing with temperature",
        ),
        _effect(
            "brush_drop", 0.50, (0.1, 1.0),
            "carbon/precious-metal brush contact drop, about constant while current "
            "flows (both PWM phases), zero when the current is zero",
            "V - I Ra keeps the drop: speed overestimated by about drop / Ke "
            "(times the conduction fraction in discontinuous conduction)",
        ),
        _effect(
            "saturation", 4.0, (1.0, 8.0),
            "armature reaction: armature current weakens the net air-gap flux, "
            "Ke(I) = Ke (1 - s I) for torque and back-EMF alike",
            "less back-EMF per rad/s at high current: speed underestimated by s I n, "
            "error growing with current",
        ),
        _effect(
            "current_offset", 8.0, (-20.0, 20.0),
            "DC offset of the current channel (shunt amplifier / ADC offset): "
            "i_A = I + offset",
            "V - (I + offset) Ra: speed underestimated by Ra offset / Ke for a "
            "positive offset, constant in speed",
        ),
        _effect(
            "v_gain", 0.8, (-2.0, 2.0),
            "gain error of the voltage channel (divider tolerance, ADC reference): "
            "v_V = (1 + g) V",
            "speed overestimated by g V / Ke for g > 0: error proportional to V",
        ),
        _effect(
            "v_offset", 0.0, (-100.0, 100.0),
            "DC offset of the voltage channel (a divider's reference, an op-amp or ADC "
            "offset): v_V = V + offset; off in the default preset (the paper's bench reads "
            "0 V at rest)",
            "speed overestimated by offset / Ke for a positive offset, the same at every "
            "speed and current",
        ),
        _effect(
            "ripple", 15.0, (5.0, 30.0),
            "commutation ripple: the current dips each time a brush shorts a coil, "
            "6 times per motor revolution (3-slot rotor); amplitude in % of the mean "
            "current; modelled as an EMF dip so V is unchanged",
            "zero-mean noise on I, hence on M2; averages out over a long sample "
            "period, visible at 100 Hz and above",
        ),
        _effect(
            "inductance", 2.5, (1.0, 5.0),
            "armature inductance La: current lags voltage with tau = La / R, PWM "
            "current ripple, continuous/discontinuous conduction through the diode",
            "no bias in steady state (La dI/dt averages out); at high sample rates "
            "La dI/dt / Ke appears at every step of V or load",
        ),
    ]
}

EFFECT_NAMES = tuple(EFFECTS)

# The forms in which the bench can carry an effect: real physics never matches one library
# term exactly, so the diagnosis is tested on effects hidden in forms other than the
# library's (test/py/test_diagnosis_forms.py). The first form of each is the default.
SATURATION_ONSET_A = 0.3     # "onset": no armature reaction below this current
BRUSH_KNEE_SOFT_A = 0.1      # "knee_100mA": the drop reaches half its value at 100 mA
BRUSH_EXP_A = 0.05           # "exp_50mA": 1 - exp(-i / 50 mA)
MAGNET_LAG_S = 600.0         # "lag_600s": the magnets' own node, 600 s behind the case
WARMUP_S = 300.0             # "warmup": a sensor offset settling after power-up,
WARMUP_AT_ONCE = 0.8         # ... this share of it at once (an amplifier's drift while it warms)
V_BOW_V = 8.0                # "bowed": the voltage channel's gain error g at 8 V, 0 at 0 V
# Forms outside every library form (issue 21, item 7; test/py/test_diagnosis_forms.py):
BRUSH_TANH_A = 0.3           # "tanh_300mA": a smooth saturating drop tanh(i / 300 mA)
SATURATION_LATE_ONSET_A = 0.6  # "onset_600mA": no armature reaction below 600 mA
DRIFT_RISE_K = 30.0          # "case": an offset growing with the case's rise, all of it this far above ambient
_CASE_DRIFT = (f"an offset that follows the case temperature: none at ambient, all of it {DRIFT_RISE_K:g} K "
               "above (the channel's electronics on the motor's housing, drifting as it warms)")
_WARMUP = (f"an offset that settles after power-up: {WARMUP_AT_ONCE:.0%} of it at once, the rest with a "
           f"{WARMUP_S:g} s time constant (an amplifier warming up)")
FORMS = {
    "saturation": {
        "linear": "Ke (1 - s |i|)",
        "quadratic": "Ke (1 - s i^2 / 1 A): the field weakens with the square of the current",
        "onset": f"Ke (1 - s max(0, |i| - {SATURATION_ONSET_A:g} A)): none below the onset current",
        "onset_600mA": f"Ke (1 - s max(0, |i| - {SATURATION_LATE_ONSET_A:g} A)): none below a late onset current",
    },
    "brush_drop": {
        "constant": "the full drop whenever current flows (a hard switch at zero current)",
        "knee_100mA": f"drop i / (i + {BRUSH_KNEE_SOFT_A * 1000:g} mA), at the mean current: a soft contact film",
        "exp_50mA": f"drop (1 - exp(-i / {BRUSH_EXP_A * 1000:g} mA)), at the mean current",
        "tanh_300mA": f"drop tanh(i / {BRUSH_TANH_A * 1000:g} mA), at the mean current: a smooth saturating drop",
    },
    "thermal_ra": {
        "winding": "the copper at the winding node's temperature (it runs hotter than the case under load)",
        "case": "the copper at the case temperature (a winding tightly coupled to its case)",
    },
    "magnet_thermal": {
        "case": "the magnets at the case temperature (stator magnets bonded to the can)",
        "winding": "the magnets at the winding node's temperature (magnets heated across the air gap)",
        "lag_600s": f"the magnets as a node of their own, {MAGNET_LAG_S:g} s behind the case (their heat capacity "
                    "behind a bond line)",
    },
    "current_offset": {
        "constant": "a fixed offset of the current channel",
        "warmup": _WARMUP,
        "case": _CASE_DRIFT,
    },
    "v_offset": {
        "constant": "a fixed offset of the voltage channel",
        "warmup": _WARMUP,
        "case": _CASE_DRIFT,
    },
    "v_gain": {
        "constant": "a fixed gain error (divider tolerance, ADC reference)",
        "bowed": f"a gain error growing with the voltage, g V / {V_BOW_V:g} V (a bowed transfer curve: "
                 "a divider's self-heating, the ADC's integral nonlinearity)",
    },
}


def warmup_share(form: str, t_s):
    """The share of a sensor offset present at time t_s after power-up (1: all of it)."""
    if form == "warmup":
        return 1.0 - (1.0 - WARMUP_AT_ONCE) * np.exp(-np.asarray(t_s, float) / WARMUP_S)
    return np.ones_like(np.asarray(t_s, float))


def offset_share(form: str, t_s, case_C, ambient_C: float):
    """The share of a sensor offset present at time t_s after power-up with the case at
    case_C (1: all of it): the warm-up's (warmup_share), or the case's rise over DRIFT_RISE_K
    ("case": an offset drifting with the temperature of the electronics)."""
    if form == "case":
        return (np.asarray(case_C, float) - ambient_C) / DRIFT_RISE_K
    return warmup_share(form, t_s)


def v_gain_share(form: str, v_V):
    """The gain error's share at the (true) voltage v_V: 1 for a fixed gain."""
    if form == "bowed":
        return np.asarray(v_V, float) / V_BOW_V
    return np.ones_like(np.asarray(v_V, float))


def saturation_shape(form: str, i_A: float) -> float:
    """How the armature reaction grows with the (non-negative) current, in A."""
    if form == "quadratic":
        return i_A * i_A
    if form == "onset_600mA":
        return i_A - SATURATION_LATE_ONSET_A if i_A > SATURATION_LATE_ONSET_A else 0.0
    if form == "onset":
        return i_A - SATURATION_ONSET_A if i_A > SATURATION_ONSET_A else 0.0
    return i_A


def brush_share(form: str, i_A: float) -> float:
    """The share of the full brush drop at the (non-negative) mean current; 1 for the
    default form (the switched circuit applies it whenever current flows)."""
    if form == "knee_100mA":
        return i_A / (i_A + BRUSH_KNEE_SOFT_A)
    if form == "exp_50mA":
        return -math.expm1(-i_A / BRUSH_EXP_A)
    if form == "tanh_300mA":
        return math.tanh(i_A / BRUSH_TANH_A)
    return 1.0


@dataclasses.dataclass
class Bench:
    """Every physical and sensor parameter of the bench. Effects live in `effects`."""

    # --- supply and power stage (paper 3.4-3.5, App. A) ---
    # Bench hardware comes from hpddo/bench.py (shared with the firmware); the twin's own
    # values differ only where listed in bench.TWIN_OVERRIDES (kept for data/default).
    supply_V: float = _HW.supply_V  # paper: 12 V gear motors, 12 V supply
    pwm_hz: float = _HW.pwm_hz  # Arduino UNO analogWrite on pins 3/9/10/11: 16 MHz / 64 / 510
    r_shunt_ohm: float = _HW.shunt_ohm  # paper App. A item 5 (0.5 ohm 10 W), in the armature loop
    r_dson_ohm: float = 0.07  # IRFZ24N datasheet 70 mOhm at Vgs 10 V (TLP250 gate drive)
    diode_vf_V: float = 0.40  # MBR60100CT Schottky at < 1 A (datasheet curve), assumed
    diode_r_ohm: float = 0.03  # assumed slope resistance
    # --- motor under test, lumped at the output shaft (gearbox 1:4.4) ---
    gear_ratio: float = _HW.gear_ratio  # paper App. A item 6
    ra_ohm: float = 4.50  # paper 4.1: multimeter mean at about 31 C
    ra_ref_C: float = 31.0  # temperature of that measurement (paper: ~31 C)
    ke_vs_per_rad: float = 0.355  # true EMF constant at ra_ref_C, zero current; chosen so the
    # paper's eq. 20 identification on the default set returns ~0.406 (see docs/twin.md)
    # (torque constant = ke_vs_per_rad in SI; gearbox losses are in the friction terms)
    # --- mechanics (output shaft; both machines + coupler), assumed ---
    j_kgm2: float = 3.0e-4
    b_motor_nms: float = 2.5e-3  # viscous, motor + its gearbox
    tc_motor_nm: float = 0.055  # Coulomb, motor + its gearbox
    b_gen_nms: float = 1.5e-3  # viscous, generator + its gearbox
    tc_gen_nm: float = 0.040  # Coulomb, generator + its gearbox
    # --- generator and relay loads ---
    ke_gen_vs_per_rad: float = 0.15  # generator EMF constant at the shared shaft, assumed
    r_gen_ohm: float = 1.5  # generator winding + brushes, assumed
    r_relay_ohm: float = 0.05  # relay contact + wiring, assumed
    load_ohm: tuple = _HW.load_ohm  # load 0 = open, 1 = 0.5 ohm, 2 = 0.01 ohm (paper)
    # --- thermal (two nodes: winding, case), assumed, tuned to the paper's 31.7 -> 71.3 C ---
    ambient_C: float = 31.7  # paper 3.6.1: case at the start of the long run
    c_winding_J_per_K: float = 6.0
    r_winding_case_K_per_W: float = 1.5
    c_case_J_per_K: float = 220.0
    r_case_amb_K_per_W: float = 6.3
    # --- measurement chain ---
    adc_bits: int = _HW.adc_bits
    adc_vref_V: float = _HW.adc_ref_V
    adc_conv_per_s: float = _HW.adc_conv_per_s  # 16 MHz / 128 / 13 cycles, free running
    v_div_gain: float = _bench.TWIN_OVERRIDES["v_div_gain"][0]  # twin override (bench: 1/3):
    # divider + level shift, ADC = 0.30 (v + v_shift); see bench.TWIN_OVERRIDES
    v_shift_V: float = _bench.TWIN_OVERRIDES["v_shift_V"][0]  # twin override (bench: 0); so the -0.4 V freewheel plateau stays inside the range
    i_gain_V_per_A: float = _HW.shunt_ohm * _HW.shunt_gain  # the shunt itself
    adc_noise_lsb: float = 0.5  # per conversion, rms
    encoder_ppr: int = _HW.encoder_ppr  # pulses per motor revolution, quadrature -> 44 counts
    temp_step_C: float = 0.0625  # DS18B20 12-bit
    temp_period_s: float = 0.75  # DS18B20 12-bit conversion time: a new reading each 750 ms
    ripples_per_rev: int = _HW.ripples_per_rev  # commutation events per motor revolution (3 slots, 2 brushes)
    noise: bool = True  # ADC noise / PWM aliasing / sensor noise on or off
    glitches: int = 0  # rare single-sample sensor glitches per recording
    # --- effects: magnitude in the unit of EFFECTS[name], 0 = off ---
    effects: dict = dataclasses.field(default_factory=lambda: {n: 0.0 for n in EFFECT_NAMES})
    # --- the form of an effect where it is not the first of FORMS[name] ---
    forms: dict = dataclasses.field(default_factory=dict)

    def effect(self, name: str) -> float:
        return float(self.effects.get(name, 0.0))

    def form(self, name: str) -> str:
        """The form in which the bench carries effect `name` (FORMS; the first by default)."""
        known = FORMS.get(name, {})
        f = self.forms.get(name, next(iter(known), ""))
        if known and f not in known:
            raise ValueError(f"unknown form {f!r} of {name} (known: {', '.join(known)})")
        return f

    def effect_si(self, name: str) -> float:
        """The magnitude of effect `name` in SI (its PhysicsParams unit: 1/K, A, H...)."""
        return EFFECTS[name].to_si(self.effect(name))

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["load_ohm"] = [None if math.isinf(x) else x for x in self.load_ohm]
        d["effects"] = {n: self.effect(n) for n in EFFECT_NAMES}
        if self.forms:
            d["forms"] = {n: self.form(n) for n in sorted(self.forms)}
        else:
            del d["forms"]
        return d


PRESETS = ("default", "ideal")


def preset(name: str = "default") -> Bench:
    """``default``: the paper's bench with every effect at its default magnitude and a
    few sensor glitches. ``ideal``: same bench, every effect off, no glitches (the
    sensor chain still quantises and adds noise)."""
    if name == "default":
        return Bench(effects={n: e.default for n, e in EFFECTS.items()}, glitches=3)
    if name == "ideal":
        return Bench()
    raise ValueError(f"unknown preset {name!r} (known: {', '.join(PRESETS)})")


def with_forms(bench: Bench, **forms) -> Bench:
    """A copy of ``bench`` carrying the given effects in the given forms (FORMS)."""
    out = dataclasses.replace(bench, forms={**bench.forms, **forms})
    for n in forms:
        if n not in FORMS:
            raise ValueError(f"effect {n!r} has one form only (forms exist for {', '.join(FORMS)})")
        out.form(n)
    return out


def with_effects(bench: Bench, **magnitudes) -> Bench:
    """A copy of ``bench`` with the given effects set (magnitude in physical unit)."""
    eff = dict(bench.effects)
    for k, v in magnitudes.items():
        if k not in EFFECTS:
            raise ValueError(f"unknown effect {k!r} (known: {', '.join(EFFECT_NAMES)})")
        eff[k] = float(v)
    return dataclasses.replace(bench, effects=eff)


# ---------------------------------------------------------------------------------------
# The ripple acquisition mode (issue 23): a high-rate current burst per window, off by
# default (hpddo twin --ripple-hz, generate(..., ripple=...)); twin/ripple.py synthesises it,
# docs/bench-log.md ("Ripple bursts") gives its file, docs/ripple.md the guide and
# docs/ripple-counting.md ("Speed from the ripple") the estimator.

@dataclasses.dataclass(frozen=True)
class BurstParam:
    """One parameter of the ripple mode: its name, unit, default, typical range and physics."""

    name: str
    unit: str
    default: float
    typical: tuple
    physics: str


RIPPLE_BURST = {
    p.name: p
    for p in [
        BurstParam("sample_hz", "Hz", 10000.0, (8000.0, 20000.0),
                   "current samples per second in the ripple mode: one per PWM period at a fixed phase "
                   "(the middle of the on-time), so the PWM runs at this frequency in the mode"),
        BurstParam("coil_emf_pct", "%", 3.0, (1.0, 8.0),
                   "the winding's part of the main line: the share of the back-EMF lost while a brush "
                   "shorts a coil, over the loop resistance (the brushes' part is the effect `ripple`, "
                   "in % of the mean current)"),
        BurstParam("sub2_pct", "%", 1.0, (0.0, 10.0),
                   "rotor asymmetry: the line at f/2, in % of the back-EMF over the loop resistance "
                   "(unequal coil EMFs), so it grows with speed where the brushes' part grows with current"),
        BurstParam("sub3_pct", "%", 0.6, (0.0, 10.0), "rotor asymmetry: the line at f/3, as sub2_pct"),
        BurstParam("sub6_pct", "%", 1.2, (0.0, 10.0),
                   "rotor asymmetry: the line at f/6 (once per motor revolution for 6 ripples per "
                   "revolution), as sub2_pct"),
        BurstParam("bar_fault_pct", "%", 0.0, (0.0, 50.0),
                   "a damaged commutator: one segment's contact resistance raised by this % of the loop "
                   "resistance, so the current dips while that segment carries it (under either brush, "
                   "twice per revolution); 0 = a healthy commutator"),
        BurstParam("harmonic2_pct", "%", 30.0, (10.0, 50.0),
                   "second harmonic of the main line, in % of its amplitude (a commutation dip is not a sine)"),
        BurstParam("bounce_pct", "%", 2.0, (0.5, 5.0),
                   "brush bounce: broadband noise on the current, rms in % of the mean current"),
        BurstParam("interference_hz", "Hz", 50.0, (10.0, 5000.0),
                   "an interference line at a fixed frequency (mains, a digital bus aliased into the band)"),
        BurstParam("interference_mA", "mA", 5.0, (0.0, 20.0), "the interference line's amplitude"),
        BurstParam("jitter_us", "us", 0.2, (0.05, 1.0),
                   "rms timing jitter of the sample within the PWM period: the error is the on-time "
                   "current slope (Vs - E - R i) / La times it"),
        BurstParam("burst_s", "s", 0.0, (0.0, 2.0),
                   "burst length per window from the window's start; 0 = the whole window"),
    ]
}


def declared_values(declared: dict, values: dict, what: str) -> dict:
    """{name: value} of the declared parameters (their defaults) with values given over them, each
    name checked against the declaration (a ValueError names the unknown ones and the known)."""
    unknown = sorted(set(values) - set(declared))
    if unknown:
        raise ValueError(f"unknown {what} parameter(s) {', '.join(unknown)} (known: {', '.join(declared)})")
    out = {n: p.default for n, p in declared.items()}
    out.update({k: float(v) for k, v in values.items()})
    return out


def ripple_burst(**values) -> dict:
    """The ripple mode's parameters (RIPPLE_BURST defaults, names checked) as {name: value}."""
    out = declared_values(RIPPLE_BURST, values, "ripple-mode")
    if not out["sample_hz"] > 0:
        raise ValueError("sample_hz must be > 0")
    return out


def params_md(params) -> str:
    """A Markdown table of declared parameters (name, unit, default, typical range, physics)."""
    rows = ["| name | unit | default | typical | physics |", "|---|---|---|---|---|"]
    for p in params:
        lo, hi = p.typical
        rows.append(f"| `{p.name}` | {p.unit} | {p.default:g} | {lo:g}..{hi:g} | {schema.md_cell(p.physics)} |")
    return "\n".join(rows) + "\n"


def ripple_burst_md() -> str:
    """The ripple mode's parameters table of docs/ripple-counting.md, from RIPPLE_BURST."""
    return params_md(RIPPLE_BURST.values())


# ---------------------------------------------------------------------------------------
# The coast probe (issue 33, item 7; twin/coast.py, docs/ripple-coast.md): the drive held off
# for a few milliseconds at a fixed period, so the terminals show the back-EMF itself; off
# unless asked (twin.coast.warmup), so no recording or study without it changes.

COAST_PROBE = {
    p.name: p
    for p in [
        BurstParam("probe_s", "s", 0.004, (0.002, 0.010),
                   "how long the drive is held off per probe: long enough for the armature current to "
                   "freewheel to zero (La / R about 0.5 ms, sped up by the back-EMF) and leave some "
                   "milliseconds of open terminals, short against the mechanical time constant (the shaft "
                   "slows about 2 % over 4 ms under full friction); also the log's row period in the twin's "
                   "warm-up, so a probe is one row"),
        BurstParam("period_s", "s", 1.5, (1.0, 2.0),
                   "one probe every period_s: often against the winding's thermal time constant "
                   "(C_w R_wc, 9 s on the twin), rare enough that the drive loses 0.3 % of its time"),
        BurstParam("burst_s", "s", 0.4, (0.4, 1.0),
                   "the current burst kept on each side of a probe (before the cut, after the drive is back) "
                   "for the ripple count of the speed there; the rest of the run keeps its log rows only"),
    ]
}


def coast_probe(**values) -> dict:
    """The coast probe's parameters (COAST_PROBE defaults, names checked) as {name: value}."""
    out = declared_values(COAST_PROBE, values, "coast-probe")
    if not (out["probe_s"] > 0 and out["period_s"] > 2 * out["probe_s"]):
        raise ValueError("probe_s must be > 0 and period_s more than twice probe_s")
    return out
