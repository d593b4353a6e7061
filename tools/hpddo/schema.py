"""The physics parameters and the effect library, declared once.

Every parameter of the physics model M2 (hpddo::PhysicsParams) and every physical effect
is one record below: its name, the field that carries it, its SI unit, how it is shown
(unit and scale), its plausible range, its meaning, which recording excites it, which
experiment separates it from the effects it resembles, and its bit. Everything else is
derived from these records:

  * lib/hpddo_core/src/hpddo/params_gen.h (generated, committed): the PhysicsParams
    struct with the units in comments, the Effect bit enum, kParamsSchema and
    hpddo::for_each_param(), the field order of a model header's initialiser, of
    hpddo::model_checksum() and of the parity probe (test/parity/effects_probe.cpp);
  * the Python PhysicsParams dataclass and EFFECT_BITS (re-exported by physics.py);
  * the effect library (effects.LIBRARY), the twin's effect names and shown units
    (twin/params.py) and the diagnosis' separating recordings (ranking.SEPARATORS).

The struct order is: BASE, then each effect's coefficient in the order of EFFECTS, then
the effects' shape parameters (Shape, in the same order), then STATE, then the effect bits. Regenerate after any change (a pytest compares byte for byte; hpddo/regenerate.py):

    cd tools && ../.venv/bin/python -m hpddo.regenerate --write      # or --check

Adding an effect: one Effect record appended to EFFECTS (next free bit), its term in
physics.h and physics.py, the generator above (docs/add-effect.md).
"""
from __future__ import annotations

import dataclasses
import pathlib
import zlib

GENERATOR = "hpddo.schema 1"
ROOT = pathlib.Path(__file__).resolve().parents[2]


def quantity(value: float, unit: str) -> str:
    """A value with its unit as text; a dimensionless one ("1") without it."""
    return f"{value:g}" if unit == "1" else f"{value:g} {unit}"


@dataclasses.dataclass
class Limits:
    """The readings the observer accepts (limits.h, hpddo::Limits; a model header carries
    them): the channels' full scale and the temperature sensor's range. A sample outside
    is invalid on the boards, and no recording row outside is used to fit a model."""

    v_max_V: float = 40.0      # largest |v_V| the voltage channel can report, V
    i_max_A: float = 10.0      # largest |i_A| the current channel can report, A
    temp_min_C: float = -55.0  # the temperature sensor's range (DS18B20), C
    temp_max_C: float = 125.0


@dataclasses.dataclass(frozen=True)
class Param:
    """One float field of PhysicsParams that is no effect coefficient."""

    field: str
    unit: str                   # SI unit
    meaning: str                # one line, the C++ field comment
    default: float | None = 0.0  # None: required (no default in the Python dataclass)


@dataclasses.dataclass(frozen=True)
class Shape:
    """A shape parameter of an effect: how its term depends on its input, beyond the
    coefficient's size. Real physics never matches one library form exactly (armature
    reaction may grow with |i| or with i^2, a brush drop may switch on over 20 mA or over
    100 mA), so an effect carries the forms physics allows as a family: the default is
    the library's base form, and the fit moves the shape within its bounds wherever the
    effect is named. The diagnosis names the effect, not the form."""

    field: str
    unit: str                   # SI unit
    meaning: str                # one line, the C++ field comment
    default: float              # the base form (the value a model without the effect carries)
    bounds: tuple               # (lo, hi): the range of forms physics allows, SI
    scale: float                # a typical step of the field, SI (parameter scaling in fits)
    forms: str                  # the forms the range covers, in words
    # The widened family (effects.fit): where the fit of the base family stops at an edge of
    # `bounds` that `widened` extends, the data pull the form beyond the base family, and
    # the effect is fitted again in the widened one: this shape within `widened`, and the
    # effect's `extension` shapes (held at their default, the base form, otherwise) free.
    widened: tuple | None = None  # (lo, hi) of the widened family, containing bounds
    extension: bool = False     # fitted only in the widened family
    # The edge ("lo", "hi"; "" for neither) toward which the term becomes a straight line in its
    # input over any range of it: a brush drop's knee far beyond the currents run is brush_V / knee
    # times the current, a resistance. A current's form stopped there trades against I Ra itself
    # (diagnosis intervals._sizes_of_unfixed_forms).
    straight_at: str = ""

    def param(self, effect: str) -> Param:
        return Param(self.field, self.unit, f"{effect} shape: {self.meaning}", self.default)


@dataclasses.dataclass(frozen=True)
class Effect:
    """One effect of the library: one coefficient of PhysicsParams, zero switches it off."""

    name: str
    bit_index: int        # its bit in PhysicsParams::effects is 1 << bit_index
    field: str            # PhysicsParams field carrying the coefficient
    unit: str             # SI unit of the field
    show_scale: float     # field value x show_scale = value in show_unit
    show_unit: str
    coefficient: str      # what the coefficient is, one line (the C++ field comment)
    summary: str          # the effect in a few words (the C++ enum comment)
    meaning: str          # physical meaning, one sentence
    typical: str          # typical values, in words
    plausible: tuple      # (lo, hi) plausible range of the field value, SI
    physical: tuple       # (lo, hi): the plausible range widened 2x; a fit outside is not this effect
    scale: float          # a typical magnitude of the field, SI (parameter scaling in fits)
    signature: str        # what the speed error of a missing effect scales with
    excited_by: str       # which recording makes the effect visible
    thermal: bool = False  # uses the temperature
    # The measured channel its term is a function of ("current", "voltage"; "" for neither): a
    # faulty channel (diagnosis/channels.py) leaves the effects that read it not concluded.
    reads: str = ""
    # Its term follows the case temperature as read (the channels' electronics sit on or
    # near the motor), without the winding node: the offsets' drift. Scored only where the
    # log reads a temperature (elsewhere the term is zero, t_ref throughout).
    case_temperature: bool = False
    # A channel's static calibration (an offset or a gain of the bench's electronics), not the motor's physics: where
    # the rows cannot tell it from a wrong Ra within the reading's tolerance, it is not named (diagnosis
    # core.through_zero). At one supply V - I Ra trades Ke against such an offset or gain; an offset drifting with
    # the case temperature follows the warm-up, which a wrong Ra does not, and is not one
    calibration: bool = False
    separated_from: tuple = ()  # ((other effect, recording that tells the two apart), ...)
    # A coefficient that is a material constant (thermal effects only): its value, held where
    # the temperature scale is unknown (no temperature read) or where the effect it shares
    # its work with is named too; the band within which a fitted value is that material; and
    # what the diagnosis calls it ("copper's coefficient", "copper plus magnets").
    material: float | None = None
    material_band: tuple | None = None
    material_name: str = ""
    # The effect that can take over this one's work when the fit lands outside material_band
    # (both follow the temperature): the diagnosis' material check (docs/diagnosis.md).
    shares_work_with: str = ""
    # Its shape parameters (Shape): the forms of the term that physics allows.
    shapes: tuple = ()

    def is_material(self, value: float) -> bool:
        """Whether a fitted coefficient lies within the band of its material constant."""
        lo, hi = self.material_band
        return lo <= value <= hi

    @property
    def bit(self) -> int:
        """The effect's bit mask in PhysicsParams::effects."""
        return 1 << self.bit_index

    @property
    def cpp_name(self) -> str:
        return "kEffect" + "".join(w.capitalize() for w in self.name.split("_"))

    def param(self) -> Param:
        return Param(self.field, self.unit, f"{self.name}: {self.coefficient}", 0.0)

    def to_si(self, shown: float) -> float:
        return shown / self.show_scale

    def show(self, value: float) -> str:
        return f"{value * self.show_scale:+.3g} {self.show_unit}"

    def is_physical(self, value: float) -> bool:
        """Whether a fitted coefficient can be this effect at all (strictly inside `physical`)."""
        lo, hi = self.physical
        return lo < value < hi

    def plausibility(self, value: float) -> tuple[bool, str]:
        lo, hi = self.plausible
        ok = lo <= value <= hi
        rng = f"{lo * self.show_scale:.3g}..{hi * self.show_scale:.3g} {self.show_unit}"
        return ok, (f"{self.show(value)} within the plausible {rng}" if ok
                    else f"{self.show(value)} outside the plausible {rng}")


@dataclasses.dataclass(frozen=True)
class BenchEffect:
    """An effect the bench twin has but the physics model carries no term for."""

    name: str
    unit: str
    show_scale: float
    show_unit: str
    meaning: str

    def to_si(self, shown: float) -> float:
        return shown / self.show_scale


# ---------------------------------------------------------------------------------------
# The declarations

BASE = (
    Param("ra_ohm", "ohm", "armature resistance at t_ref_C", None),
    Param("ke_vs_per_rad", "V s/rad", "back-EMF constant at t_ref_C and zero current", None),
    Param("t_ref_C", "C", "temperature at which ra_ohm and ke_vs_per_rad hold", 25.0),
)

EFFECTS = (
    Effect("thermal_ra", 0, "ra_tc_per_K", "1/K", 100.0, "%/K",
           "relative change of Ra per kelvin (copper +0.00393)",
           "copper resistance rises with T",
           "copper resistance of the winding rises with temperature: Ra(T) = Ra (1 + a (T - T_ref))",
           "copper +0.393 %/K (a material constant; the band allows for the sensor's lag)",
           (0.0033, 0.0046), (0.001, 0.012), 0.004,
           "temperature rise x current",
           "a run in which the winding heats up (minutes at high current)", thermal=True,
           material=0.00393, material_band=(0.0033, 0.0046), material_name="copper",
           shares_work_with="magnet_thermal",
           separated_from=(
               ("magnet_thermal",
                "a run in which the temperature changes at a different current-to-speed ratio: e.g. a "
                "long warm-up at light load (low current, high speed) next to the heavy-load long run, "
                "or load steps while the motor is hot"),
               ("v_gain",
                "a cold run with load steps (the resistance term at constant temperature), "
                "or a check of the voltage channel against a calibrated meter"),
               ("saturation",
                "load steps at constant temperature (short, from cold) and a slow warm-up at constant load"),
           ),
           reads="current"),
    Effect("magnet_thermal", 1, "ke_tc_per_K", "1/K", 100.0, "%/K",
           "relative change of Ke per kelvin (ferrite ~ -0.002)",
           "magnet flux falls with T",
           "magnet flux, hence Ke, falls with temperature: Ke(T) = Ke (1 + b (T - T_ref))",
           "ferrite about -0.2 %/K, NdFeB -0.12 %/K", (-0.0035, -0.0003), (-0.007, -0.00015), -0.002,
           "temperature rise x speed",
           "a run in which the motor heats up (minutes at high current)", thermal=True,
           material=-0.002, material_band=(-0.0035, -0.0003), material_name="magnets",  # ferrite
           separated_from=(
               ("saturation",
                "load steps at constant temperature (short, from cold) and a slow warm-up at constant load"),
           )),
    Effect("brush_drop", 2, "brush_V", "V", 1.0, "V",
           "total brush contact drop at full conduction",
           "brush-commutator contact drop",
           "contact drop of the carbon brushes, about constant while current flows",
           "0.3..2 V for both brushes together", (0.05, 2.5), (0.025, 5.0), 0.5,
           "a constant voltage while current flows (sign of the current)",
           "runs at several speeds, including light load",
           shapes=(
               Shape("brush_knee_A", "A",
                     "current scale over which the brush drop builds up (half of it at the knee for order 1)",
                     0.02, (0.002, 0.3), 0.02,
                     "brush_V i / (|i| + knee): a drop that switches on within a few mA (hard carbon) "
                     "to one that builds up over a few hundred mA (soft graphite, film); widened: up to 1 A",
                     widened=(0.002, 1.0), straight_at="hi"),
               # A brush drop that levels off smoothly (tanh, 1 - exp) is none of i / (|i| + knee):
               # on such a bench the base form stopped at its 300 mA knee and left the physics
               # 1.26..1.42 x the true model's held-out error (docs/diagnosis-forms.md, Forms outside the
               # library). The widened family's order m runs from the base form (m = 1) to
               # i / sqrt(i^2 + knee^2) (m = 2), the straight blend between (one square root on
               # the boards): about 1.4 holds 1 - exp(-|i| / i0); tanh(|i| / i0) is sharper still
               # and sits at m = 2; knee -> 0 the hard switch.
               Shape("brush_order", "1",
                     "how sharply the brush drop levels off: 1 i/(|i|+knee), 2 i/sqrt(i^2+knee^2), the blend between",
                     1.0, (1.0, 2.0), 0.5,
                     "brush_V ((2 - m) i / (|i| + knee) + (m - 1) i / sqrt(i^2 + knee^2)): m = 1 the base form, "
                     "about 1.4 an exponential 1 - exp(-|i| / i0), 2 an algebraic drop as sharp as tanh's "
                     "nearly (the widened family only)",
                     extension=True),
           ),
           separated_from=(
               ("current_offset",
                "rows at zero and at very low current with the motor turning (coasting at duty 0, or "
                "a run at very light load): a brush drop vanishes with the current, an offset does not"),
               ("v_gain",
                "a sweep over the full duty range at light load: a gain error grows with the voltage, "
                "a brush drop does not"),
           ),
           reads="current"),
    Effect("saturation", 3, "ke_sat_per_A", "1/A", 100.0, "%/A",
           "relative fall of Ke per ampere of |i|",
           "armature reaction, Ke falls with |i|",
           "armature reaction weakens the field at high current: Ke(I) = Ke (1 - s |I|)",
           "a few %/A", (0.002, 0.15), (0.001, 0.3), 0.04,
           "current x speed",
           "runs at different loads (currents) at similar speeds",
           separated_from=(
               ("v_gain", "load steps at one duty (same voltage, different currents)"),
           ),
           shapes=(
               Shape("ke_sat_quad", "1",
                     "share of the armature reaction that grows with i^2 (per 1 A) instead of |i|",
                     0.0, (0.0, 1.0), 0.3,
                     "Ke (1 - s |i| (1 - q + q |i| / 1 A)): q = 0 linear in |i|, q = 1 quadratic (the "
                     "onset of saturation above a current lies between)"),
           ),
           reads="current"),
    Effect("current_offset", 4, "i_offset_A", "A", 1000.0, "mA",
           "reading minus true current",
           "offset of the current channel",
           "DC offset of the current channel: the reading minus the true current",
           "a few mA to tens of mA", (-0.05, 0.05), (-0.1, 0.1), 0.01,
           "a constant voltage Ra x offset, at every current including zero",
           "rows at zero or very low current with the motor turning (coasting at duty 0)",
           separated_from=(
               ("v_gain", "a sweep over the full duty range at light load and rows at zero current"),
           ),
           calibration=True, reads="current"),
    Effect("v_gain", 5, "v_gain", "1", 100.0, "%",
           "reading / true voltage - 1",
           "gain error of the voltage channel",
           "gain error of the voltage channel: reading / true voltage - 1",
           "|g| below about 5 % (divider tolerance, ADC reference)", (-0.05, 0.05), (-0.1, 0.1), 0.01,
           "the terminal voltage",
           "runs at different voltages with different currents",
           calibration=True, reads="voltage"),
    Effect("inductance", 6, "la_H", "H", 1000.0, "mH",
           "armature inductance",
           "la di/dt, visible at high rates",
           "armature inductance: La di/dt in the voltage balance",
           "0.5..20 mH for small PMDC motors", (0.0005, 0.02), (0.00025, 0.04), 0.003,
           "the rate of change of the current",
           "a recording at 1 kHz or faster with steps of duty",
           reads="current"),
    Effect("v_offset", 7, "v_offset_V", "V", 1000.0, "mV",
           "reading minus true voltage",
           "offset of the voltage channel",
           "DC offset of the voltage channel (a divider's reference, an ADC or op-amp offset): "
           "the reading minus the true voltage",
           "a few mV to a few hundred mV", (-0.3, 0.3), (-0.6, 0.6), 0.05,
           "a constant voltage at every current and speed",
           "rows at standstill with the supply off (the reading of zero volts), or runs at several voltages",
           separated_from=(
               ("current_offset",
                "rows at standstill with the supply off (duty 0, motor stopped): the voltage reading "
                "there is the voltage offset and the current reading the current offset"),
               ("brush_drop",
                "rows at zero and at very low current with the motor turning (coasting): a brush drop "
                "vanishes with the current, a voltage offset does not"),
           ),
           calibration=True, reads="voltage"),
    # Offsets that drift (issue 21, item 7): a channel's offset following the temperature of
    # its electronics, which sit on or near the motor and warm with its case. An offset in i
    # shifts V - I Ra by Ra di whatever the current's size and sign, at standstill too, where
    # Ra(T) scales with the current; at one operating point during a warm-up the two are
    # the same speed error (ranking: "cannot be told apart", with the recording that would).
    # One drift for both channels: the speed sees V - I Ra, where a voltage channel's drift dv
    # is the current channel's -dv / Ra, and only rows at standstill with the supply off while
    # warm read which channel drifts (the constant offsets' REST_READ). A voltage-channel drift
    # of its own was built and measured too: the same verdicts and figures (its drift named as
    # this one's with the opposite sign, "not told apart"), and over the UNO observer build's
    # 75 % flash budget: 24 196 bytes at best of eight arrangements of the two terms, against
    # 24 192 allowed (this one: 24 148; docs/diagnosis-forms.md, Offsets that drift).
    Effect("current_offset_drift", 8, "i_offset_tc_A_per_K", "A/K", 1000.0, "mA/K",
           "change of the current channel's offset per kelvin of the case above t_ref_C",
           "current offset drifting with the case temperature",
           "the current channel's offset follows the temperature of its electronics (the case reading): "
           "i_offset + c (T_case - T_ref); a voltage channel drifting by dv per kelvin shows as -dv / Ra",
           "a Hall sensor's zero drifts up to about 1 mA/K (a fraction of a mV/K over 100..200 mV/A), a "
           "shunt amplifier's µV/K over a 0.5 ohm shunt µA/K; a level-shifted voltage divider whose "
           "reference drifts 100 ppm/K under a gain of 12, a few mV/K: about -1 mA/K through 4.5 ohm",
           (-0.0015, 0.0015), (-0.003, 0.003), 0.0005,
           "Ra x the case's rise, at every current including zero",
           "a warm-up with rows at several currents, or at standstill with the supply off, while warm "
           "and while cold (a log with temp_C)",
           case_temperature=True,
           separated_from=(
               ("thermal_ra",
                "load steps (several currents, light load included) while the motor is warm, or rows at "
                "standstill with the supply off before and after a warm-up: an offset's drift shifts "
                "V - I Ra by the same voltage at every current and at zero, Ra(T) in proportion to the "
                "current"),
               ("magnet_thermal",
                "several speeds at one current while warm (a duty sweep at light load after a warm-up): the "
                "magnets' error grows with the speed, an offset's drift does not"),
               ("current_offset",
                "rows at standstill with the supply off, cold and warm: the reading there is the offset "
                "at each temperature"),
               ("v_offset",
                "rows at standstill with the supply off, cold and warm: the voltage reading there is the "
                "voltage channel's offset, the current reading the current channel's, at each temperature"),
           ),
           reads="current"),
)

STATE = (
    Param("th_r_K_per_W", "K/W", "thermal state: winding-to-ambient resistance (0: no estimate)", 0.0),
    Param("th_tau_s", "s", "thermal state: time constant", 0.0),
    Param("t_amb_C", "C", "thermal state: ambient temperature", 25.0),
)


@dataclasses.dataclass(frozen=True)
class NodeParam:
    """A parameter of the winding's thermal node (a STATE field) that the effect fits estimate
    along one heat path, with its plausible and physical ranges. The path follows the log:
    "case" where it reads the case temperature (the node is the winding's rise above the
    reading: the winding-to-case path), "ambient" where it reads none (the rise above ambient:
    winding to case to ambient, in series)."""

    field: str
    path: str             # "case" or "ambient"
    show_unit: str        # shown in the unit of the field (show scale 1)
    plausible: tuple      # (lo, hi), SI
    physical: tuple       # (lo, hi): the plausible range widened 2x (lo / 2, 2 hi); the fit is held within it
    start: float          # where the fit starts (and the value the ranking assumes before any fit)
    basis: str            # where the range comes from, one line

    def show(self, value: float) -> str:
        return f"{value:.3g} {self.show_unit}"

    def at_bound(self, value: float) -> bool:
        """Whether a fitted value sits on an edge of the physical range (the data pull it further)."""
        lo, hi = self.physical
        return abs(value - lo) <= 1e-5 * lo or abs(value - hi) <= 1e-5 * hi

    def plausibility(self, value: float) -> tuple[bool, str]:
        lo, hi = self.plausible
        ok = lo <= value <= hi
        rng = f"{lo:.3g}..{hi:.3g} {self.show_unit}"
        text = f"{self.show(value)} {'within' if ok else 'outside'} the plausible {rng}"
        if self.at_bound(value):
            text += (f", at the edge of the physical {self.physical[0]:.3g}..{self.physical[1]:.3g} "
                     f"{self.show_unit} (the fit is held there; the data pull it further)")
        return ok, text


# The winding's thermal node, per heat path. A 25 mm iron-core gear motor (the 25GA371 of the
# bundled data): copper and laminations of the armature hold about 5..30 J/K; catalogue data of
# small DC motors put the winding-to-housing resistance at about 1..10 K/W and the housing-to-
# ambient resistance of a motor without heat sink at 5..30 K/W. Hence the winding's own time
# constant (C_w R_wc) of 8 s to a few minutes, and the motor's (case and winding to ambient) of
# minutes to an hour. The twin (twin/params.py): 6 J/K, 1.5 K/W to the case (9 s), 220 J/K and
# 6.3 K/W case to ambient (the slow mode 1424 s, 7.8 K/W in series).
# The resistances fall as a motor grows (a larger surface, a fan, a heat sink or a dyno's plate)
# while its heat capacities grow, so the time constants stay in the same ranges: a motor of a few
# hundred watts has some 0.1..0.5 K/W to its housing and 0.2..2 K/W to ambient. The lower ends
# take those motors in: a fixed small-motor range held a 24 V, 0.48 ohm motor's warm-up (0.46 K/W
# to ambient) at its edge, and the warm-up was then told from the same motor's other recordings
# as "another motor" (fuzz round 9's x02).
NODE = (
    NodeParam("th_r_K_per_W", "case", "K/W", (0.1, 12.0), (0.05, 24.0), 2.0,
              "winding-to-housing resistance: about 1..10 K/W for small DC motors, down to 0.1 for some hundred watts"),
    NodeParam("th_tau_s", "case", "s", (8.0, 300.0), (4.0, 600.0), 30.0,
              "armature heat capacity 5..30 J/K x 1.5..10 K/W to the housing"),
    NodeParam("th_r_K_per_W", "ambient", "K/W", (0.2, 40.0), (0.1, 80.0), 10.0,
              "winding to housing plus housing to ambient: 5..30 K/W for a small motor without heat sink, "
              "down to 0.2 for some hundred watts with a fan or a heat sink"),
    NodeParam("th_tau_s", "ambient", "s", (60.0, 3600.0), (30.0, 7200.0), 600.0,
              "the housing's heat capacity (100..500 J/K) x its path to ambient: minutes to an hour"),
)
NODE_PATHS = ("case", "ambient")


def node_param(path: str, field: str) -> NodeParam:
    """The declaration of a thermal-node field along a heat path ("case" or "ambient")."""
    for n in NODE:
        if n.path == path and n.field == field:
            return n
    raise KeyError((path, field))


# The effect bits, after every float field (uint16_t in C++, int in Python).
BITS_FIELD = "effects"
BITS_MEANING = "Effect bits that are on (informative; zero coefficients are off)"

BENCH_EFFECTS = (
    BenchEffect("ripple", "1", 100.0, "%",
                "commutation ripple of the current, relative to the mean current; zero-mean noise "
                "to the physics model, which has no term for it"),
)

# ---------------------------------------------------------------------------------------
# Derived

SHAPES = tuple(sh for e in EFFECTS for sh in e.shapes)
PARAMS = BASE + tuple(e.param() for e in EFFECTS) + tuple(sh.param(e.name) for e in EFFECTS for sh in e.shapes) + STATE
FLOAT_FIELDS = tuple(p.field for p in PARAMS)      # every float field, in struct order
FIELDS = FLOAT_FIELDS + (BITS_FIELD,)              # every field: struct, initialiser, checksum order
UNITS = {p.field: p.unit for p in PARAMS}
BY_NAME = {e.name: e for e in EFFECTS}
EFFECT_BITS = {e.name: (e.bit, e.field) for e in EFFECTS}   # name -> (bit mask, field)
ALL_EFFECTS = BY_NAME.copy()
ALL_EFFECTS.update((b.name, b) for b in BENCH_EFFECTS)
SEPARATORS = {frozenset({e.name, other}): text for e in EFFECTS for other, text in e.separated_from}


def effect(name: str):
    """The declaration of a model or bench effect by name."""
    return ALL_EFFECTS[name]


def validate() -> None:
    """Raises ValueError when the declarations contradict each other."""
    fields = [p.field for p in PARAMS] + [BITS_FIELD]
    if len(set(fields)) != len(fields):
        raise ValueError(f"duplicate PhysicsParams field in {fields}")
    for f in fields:
        if not f.isidentifier():
            raise ValueError(f"field {f!r} is no identifier")
    required = [p.default is None for p in PARAMS]
    if required != sorted(required, reverse=True):
        raise ValueError("parameters without a default must come first")
    names = [e.name for e in EFFECTS] + [b.name for b in BENCH_EFFECTS]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate effect name in {names}")
    bits = [e.bit_index for e in EFFECTS]
    if len(set(bits)) != len(bits) or not all(0 <= b < 16 for b in bits):
        raise ValueError(f"effect bits must be distinct and within 0..15: {bits}")
    pairs = []
    for e in EFFECTS:
        lo, hi = e.plausible
        if not (e.physical[0] <= lo < hi <= e.physical[1]):
            raise ValueError(f"{e.name}: plausible {e.plausible} not within physical {e.physical}")
        if e.show_scale <= 0:
            raise ValueError(f"{e.name}: show_scale must be positive")
        for other, _ in e.separated_from:
            if other not in BY_NAME or other == e.name:
                raise ValueError(f"{e.name}: separated_from names unknown effect {other!r}")
            pairs.append(frozenset({e.name, other}))
        if e.case_temperature and e.thermal:
            raise ValueError(f"{e.name}: a term follows the winding node (thermal) or the case reading, not both")
        if e.material is not None or e.material_band is not None:
            if not e.thermal:
                raise ValueError(f"{e.name}: a material constant is declared for thermal effects only")
            if e.material is None or e.material_band is None or not e.material_name:
                raise ValueError(f"{e.name}: material, material_band and material_name go together")
            if not (e.plausible[0] <= e.material_band[0] <= e.material <= e.material_band[1] <= e.plausible[1]):
                raise ValueError(f"{e.name}: material {e.material} not within material_band {e.material_band} "
                                 f"within plausible {e.plausible}")
        for sh in e.shapes:
            lo, hi = sh.bounds
            if not (lo <= sh.default <= hi and lo < hi and sh.scale > 0):
                raise ValueError(f"{e.name} shape {sh.field}: want lo <= default <= hi, lo < hi, scale > 0")
            if sh.widened is not None and not (sh.widened[0] <= lo and hi <= sh.widened[1] and sh.widened != sh.bounds):
                raise ValueError(f"{e.name} shape {sh.field}: the widened range must contain the bounds")
        if any(sh.extension for sh in e.shapes) and not any(sh.widened for sh in e.shapes):
            raise ValueError(f"{e.name}: an extension shape needs a shape whose edge widens the family")
        if e.shares_work_with:
            other = BY_NAME.get(e.shares_work_with)
            if other is None or other is e:
                raise ValueError(f"{e.name}: shares_work_with names unknown effect {e.shares_work_with!r}")
            if e.material is None or other.material is None:
                raise ValueError(f"{e.name}: shares_work_with needs a material constant on both effects")
    if len(set(pairs)) != len(pairs):
        raise ValueError("a pair of effects has two separating recordings")
    state_fields = {p.field for p in STATE}
    for path in NODE_PATHS:
        got = sorted(n.field for n in NODE if n.path == path)
        if got != ["th_r_K_per_W", "th_tau_s"]:
            raise ValueError(f"thermal node, path {path!r}: declares {got}, want th_r_K_per_W and th_tau_s once")
    for n in NODE:
        lo, hi = n.plausible
        if n.field not in state_fields or n.path not in NODE_PATHS:
            raise ValueError(f"thermal node: unknown field or path {n.field!r}, {n.path!r}")
        if not (0 < lo < hi) or n.physical != (lo / 2, 2 * hi) or not (lo <= n.start <= hi):
            raise ValueError(f"thermal node {n.path} {n.field}: want 0 < plausible, physical = (lo/2, 2 hi), "
                             "start within plausible")


# ---------------------------------------------------------------------------------------
# BEGIN the dynamic family (issue 21, item 8): inertia and friction at the output shaft
#
# On a fast recording (50 Hz and up) the speed lags the voltage through the shaft's inertia
# and friction, and the current lags it through the winding's inductance. The inductance is
# the effect "inductance" above (La di/dt in the voltage balance, la_H in PhysicsParams); the
# mechanical part is declared here, once: the balance at the output shaft
#     Kt i = J dw/dt + B w + Tc sgn(w) + T_load        (Kt = Ke in SI)
# with its parameters in DynamicsParams, a struct of its own beside PhysicsParams, so that a
# model without the family keeps its layout, its kParamsSchema and its checksum bit for bit.
# The diagnosis identifies J, B and Tc from recordings at DYNAMICS_MIN_RATE_HZ and up
# (model/dynamics.py); the boards compute the balance when the family is named
# (j_kgm2 > 0: lib/hpddo_core/src/hpddo/dynamics.h, the Python reference model/dynamics_ref.py).


@dataclasses.dataclass(frozen=True)
class DynParam:
    """One parameter of the dynamic family (a DynamicsParams field)."""

    field: str
    unit: str             # SI unit
    show_scale: float     # field value x show_scale = value in show_unit
    show_unit: str
    meaning: str          # one line, the C++ field comment
    plausible: tuple      # (lo, hi), SI
    physical: tuple       # (lo / 2, 2 hi): a fit outside is not this quantity
    basis: str            # where the range comes from, one line

    def show(self, value: float) -> str:
        return f"{value * self.show_scale:.3g} {self.show_unit}"


DYNAMICS = (
    DynParam("j_kgm2", "kg m^2", 1e7, "g cm^2",
             "inertia of the shaft and all it drives, at the output shaft (0: the family is off)",
             (1e-5, 5e-3), (5e-6, 1e-2),
             "a small gear motor's rotor (1e-6 kg m^2) times the gear ratio squared, up to a coupled load "
             "machine and flywheel"),
    DynParam("b_nms_per_rad", "N m s/rad", 1e3, "mN m s/rad",
             "viscous friction at the output shaft (bearings, gearbox oil, a coupled machine's)",
             (1e-4, 2e-2), (5e-5, 4e-2),
             "gearbox and bearings of small gear motors: a few % of the stall torque per 100 rad/s"),
    DynParam("tc_nm", "N m", 1e3, "mN m",
             "Coulomb friction at the output shaft (brushes, gear mesh, seals): a torque against the motion",
             (0.005, 0.3), (0.0025, 0.6),
             "the no-load current times Kt: 50..300 mA x 0.1..1 N m/A at the output shaft"),
    DynParam("tau_obs_s", "s", 1e3, "ms",
             "the observer's time constant: how fast the back-EMF speed pulls the mechanical model back "
             "(a filter's setting, not the motor's)",
             (0.005, 0.5), (0.0025, 1.0),
             "a few sample periods at 50..1000 Hz, within the mechanical time constant's range"),
)
DYNAMICS_INDUCTANCE = "inductance"   # the family's electrical part: the effect declared above
DYNAMICS_MIN_RATE_HZ = 50.0          # recordings at this rate and up can show the dynamics
DYN_BY_FIELD = {d.field: d for d in DYNAMICS}


def _dynamics_h() -> str:
    """The generated C++ of the dynamic family: struct DynamicsParams."""
    struct = _comment_pad([(f"  float {d.field};", f"{d.meaning}, {d.unit}") for d in DYNAMICS])
    return f"""/// The dynamic family (inertia and friction at the output shaft, with the inductance effect
/// la_H of PhysicsParams): Kt i = J dw/dt + B w + Tc sgn(w) + T_load, Kt = Ke. Computed on the
/// boards when named (j_kgm2 > 0; dynamics.h), its own struct so that PhysicsParams and
/// kParamsSchema do not change. Constructor-free, initialised in field order.
struct DynamicsParams {{
{chr(10).join(struct)}
}};

/// Number of DynamicsParams fields.
static const uint8_t kDynamicsParamCount = {len(DYNAMICS)};
"""


def _validate_dynamics() -> None:
    if len(DYN_BY_FIELD) != len(DYNAMICS) or any(f in FIELDS for f in DYN_BY_FIELD):
        raise ValueError("dynamic family: a field twice, or one that PhysicsParams already has")
    for d in DYNAMICS:
        lo, hi = d.plausible
        if not (0 < lo < hi) or d.physical != (lo / 2, 2 * hi) or not d.field.isidentifier():
            raise ValueError(f"dynamic family {d.field}: want 0 < plausible, physical = (lo/2, 2 hi)")
    if DYNAMICS_INDUCTANCE not in BY_NAME:
        raise ValueError(f"dynamic family: no effect {DYNAMICS_INDUCTANCE!r}")

# END the dynamic family
# ---------------------------------------------------------------------------------------


validate()
_validate_dynamics()


# ---------------------------------------------------------------------------------------
# The Python PhysicsParams


def _effect_names(self) -> list[str]:
    return [name for name, (bit, _) in EFFECT_BITS.items() if self.effects & bit]


def _thermal_enabled(self) -> bool:
    return self.th_r_K_per_W > 0.0 and self.th_tau_s > 0.0


def _make_params_class():
    spec = []
    for p in PARAMS:
        spec.append((p.field, float) if p.default is None else (p.field, float, dataclasses.field(default=p.default)))
    spec.append((BITS_FIELD, int, dataclasses.field(default=0)))
    cls = dataclasses.make_dataclass(
        "PhysicsParams", spec,
        namespace={"__doc__": "Lumped parameters of one assembly (SI units, speed at the output shaft); "
                              "fields as hpddo::PhysicsParams, declared in hpddo.schema.",
                   "FIELDS": FLOAT_FIELDS, "effect_names": _effect_names, "thermal_enabled": _thermal_enabled})
    cls.__module__ = __name__
    return cls


PhysicsParams = _make_params_class()


# ---------------------------------------------------------------------------------------
# Generated files


def layout_crc() -> int:
    """CRC-32 of what a model header depends on: field names, types and order, effect bits."""
    text = ";".join([f"float {f}" for f in FLOAT_FIELDS] + [f"uint16_t {BITS_FIELD}"]
                    + [f"{e.name}={e.bit_index}" for e in EFFECTS])
    return zlib.crc32(text.encode()) & 0xFFFFFFFF


def _unit_words(unit: str) -> str:
    return "dimensionless" if unit == "1" else unit


def _comment_pad(lines: list[tuple[str, str]]) -> list[str]:
    width = max(len(code) for code, _ in lines)
    return [f"{code.ljust(width)}  ///< {doc}" for code, doc in lines]


def _params_h_body() -> str:
    crc = layout_crc()
    enum = _comment_pad([(f"  {e.cpp_name} = 1u << {e.bit_index},", f"{e.name}: {e.summary}") for e in EFFECTS])
    struct = _comment_pad([(f"  float {p.field};", f"{p.meaning}, {_unit_words(p.unit)}") for p in PARAMS]
                          + [(f"  uint16_t {BITS_FIELD};", BITS_MEANING)])
    visit = "\n".join(f"  f(p.{f});" for f in FIELDS)
    all_bits = 0
    for e in EFFECTS:
        all_bits |= e.bit
    materials = _comment_pad([(f"static const float kMaterial{e.cpp_name[len('kEffect'):]} = {e.material!r}f;",
                               f"{e.name}: {e.material_name}, {_unit_words(e.unit)}")
                              for e in EFFECTS if e.material is not None])
    return f"""#ifndef HPDDO_PARAMS_GEN_H
#define HPDDO_PARAMS_GEN_H

#include <stdint.h>

namespace hpddo {{

/// CRC-32 of the parameter layout (field names, types and order, effect bits). A model
/// header asserts that it was written for this layout.
static const uint32_t kParamsSchema = 0x{crc:08x}u;

/// Bit of each effect in PhysicsParams::effects, for reporting and telemetry.
enum Effect : uint16_t {{
{chr(10).join(enum)}
}};

/// Every effect bit of the library.
static const uint16_t kEffectsAll = 0x{all_bits:04x}u;

/// The material constant of an effect (what a fitted coefficient is checked against; the
/// board's ripple counter turns Ra into a winding temperature with copper's).
{chr(10).join(materials)}

/// Lumped parameters of one motor-drivetrain assembly, all in SI units, speed
/// at the output shaft. Effect coefficients at zero switch their effect off.
/// Constructor-free: a model header initialises it in field order.
struct PhysicsParams {{
{chr(10).join(struct)}
}};

/// Number of PhysicsParams fields, the effect bits included.
static const uint8_t kPhysicsParamCount = {len(FIELDS)};

/// Calls f(p.field) for every PhysicsParams field in the schema's order, the order of
/// the struct, of a model header's initialiser and of model_checksum(): each float
/// coefficient, then the effect bits (uint16_t). Params is PhysicsParams or const
/// PhysicsParams; F has operator() for float and uint16_t (or their references).
template <class Params, class F>
inline void for_each_param(Params& p, F& f) {{
{visit}
}}

{_dynamics_h()}
}}  // namespace hpddo

#endif  // HPDDO_PARAMS_GEN_H
"""


def md_cell(text: str) -> str:
    """Text for a markdown table cell (a pipe would end the cell)."""
    return text.replace("|", "\\|")


def _effects_md() -> str:
    """The effects table of docs/core.md: one row per effect of the schema."""
    rows = ["| effect | field | SI unit | shown in | plausible | physics | excited by |",
            "|---|---|---|---|---|---|---|"]
    for e in EFFECTS:
        lo, hi = e.plausible
        rows.append(f"| {e.name} | `{e.field}` | {e.unit} | {e.show_unit} | "
                    f"{lo * e.show_scale:.3g}..{hi * e.show_scale:.3g} {e.show_unit} | {md_cell(e.meaning)} | "
                    f"{md_cell(e.excited_by)} |")
    rows += ["", "The shape parameters (`Shape`: the forms of a term physics allows, fitted wherever its "
                 "effect is named; the default is the base form; where the base family's fit stops at an "
                 "edge its widened range extends, the effect is fitted again in the widened family, "
                 "extension shapes free):", "",
             "| effect | field | SI unit | default | range | forms |", "|---|---|---|---|---|---|"]
    for e in EFFECTS:
        for sh in e.shapes:
            rng = f"{sh.bounds[0]:g}..{sh.bounds[1]:g}"
            if sh.widened is not None:
                rng += f" (widened {sh.widened[0]:g}..{sh.widened[1]:g})"
            rows.append(f"| {e.name} | `{sh.field}` | {sh.unit} | {sh.default:g} | {rng} | "
                        f"{md_cell(sh.forms)} |")
    return "\n".join(rows) + "\n"
