"""The bench, declared once: protocols, PWM, encoder, gearbox, measurement front end.

This module is the single description of the test bench of the paper (hpddo-pmdc,
sections 3.4-3.6.1 and Appendix A) that the three users of the bench share:

* the UNO firmware, through the generated header ``uno_acq/bench_gen.h``
  (``python -m hpddo.bench --write``; ``--check`` compares the bytes; the pytest
  ``test/py/test_bench_description.py`` does the same);
* the bench twin (``hpddo.twin.protocols`` takes its protocols from here,
  ``hpddo.twin.params.Bench`` its hardware constants);
* the simavr harness (``test/firmware/check_uno_sim.py`` imports this module,
  ``uno_sim.c`` includes the generated header).

Only what describes the bench hardware and the protocols is here; the plant physics
(Ke, Ra, inertia, friction, thermal) stays in ``hpddo.twin.params``.

Each value carries its source: ``paper`` (stated there), ``paper-silent`` (the paper
does not give it; the value is the one the bundled recordings were made with), or
``assumed``. Where the paper contradicts what the bundled recordings were generated
with, the paper's value is declared here and the twin's value is a documented
override (``TWIN_OVERRIDES``), kept so that ``data/default`` stays byte for byte.
"""
from __future__ import annotations

import argparse
import dataclasses
import hashlib
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
HEADER = ROOT / "uno_acq" / "bench_gen.h"


@dataclasses.dataclass(frozen=True)
class Segment:
    """A piece of a protocol with one duty and one load state in force."""

    duration_s: float
    duty: float  # 0..1
    load: int  # 0 open, 1 = load_ohm[1], 2 = load_ohm[2]


ROLES = ("train", "validation")


@dataclasses.dataclass(frozen=True)
class Protocol:
    """A named schedule of segments.

    ``role``: ``train`` for the paper's protocols (the bundled training recordings
    ``data/default``, the firmware's protocols), ``validation`` for hpddo's own protocols
    that no training recording covers (``data/validation``; the firmware does not run
    them). ``ambient_C``: the bench's ambient temperature during the protocol, the motor
    starting soaked at it (None: the bench's default, ``hpddo.twin.params.Bench.ambient_C``).
    """

    name: str
    segments: tuple  # of Segment
    source: str
    role: str = "train"
    ambient_C: float | None = None

    def __post_init__(self):
        if self.role not in ROLES:
            raise ValueError(f"protocol {self.name}: role {self.role!r} not in {ROLES}")

    @property
    def duration_s(self) -> float:
        return sum(s.duration_s for s in self.segments)

    def step_s(self) -> float:
        """The common length of every segment (the firmware's protocols have equal steps)."""
        lengths = {s.duration_s for s in self.segments}
        if len(lengths) != 1:
            raise ValueError(f"protocol {self.name}: segments of unequal length {sorted(lengths)}")
        return lengths.pop()


def _steps(name, step_s, pairs, source, **kw):
    return Protocol(name, tuple(Segment(step_s, d, k) for d, k in pairs), source, **kw)


SWEEP_DUTIES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 0.8, 0.6, 0.4, 0.2, 0.0)
LOAD_SEQUENCE = (0, 1, 2, 0, 2, 1, 0, 1, 2, 1, 0, 2)

# Validation protocol "unseen": duty/load pairs absent from every training protocol
# (training: duties 0, 0.2 ... 1.0 open; 0.8 at loads 0/1/2). Open: the duties between
# the training steps, 0.1 (below break-away: the shaft stands under PWM) to 0.9.
# Loaded: every duty but 0.8 (the only loaded training duty), 0.2 (not 0.1: at 0.1 the
# shaft stands whatever the load) to 1.0. 20 s a step (the speed settles within 1 s).
# Open first, the 0.01 ohm load last, so the motor warms little: case and winding stay
# inside the training recordings' range (measured: docs/twin.md).
UNSEEN_STEP_S = 20.0
UNSEEN_PAIRS = (
    (0.1, 0), (0.3, 0), (0.5, 0), (0.7, 0), (0.9, 0),
    (1.0, 1), (0.9, 1), (0.7, 1), (0.6, 1), (0.5, 1), (0.4, 1), (0.3, 1), (0.2, 1),
    (0.2, 2), (0.3, 2), (0.4, 2), (0.5, 2), (0.6, 2), (0.7, 2), (0.9, 2), (1.0, 2),
)
# Validation protocol "hot": training pairs on a motor hotter than any training row
# (the long run's case ends at 71.4 C). The motor starts soaked at a 55 C ambient; 20 min
# at the long run's pair heat the case to about 80 C (its time constant is about 23 min,
# so a few minutes could not), then ten 30 s steps of training pairs.
HOT_AMBIENT_C = 55.0
HOT_SEGMENTS = (  # (duration_s, duty, load)
    (1200.0, 0.8, 2),  # warm-up, the long run's pair
    (30.0, 0.8, 0), (30.0, 0.8, 1), (30.0, 0.8, 2), (30.0, 0.6, 0), (30.0, 1.0, 0),
    (30.0, 0.8, 2), (30.0, 0.8, 1), (30.0, 0.8, 0), (30.0, 1.0, 0), (30.0, 0.8, 2),
)

PROTOCOLS = {
    p.name: p
    for p in (
        _steps("sweep", 30.0, [(d, 0) for d in SWEEP_DUTIES],
               "paper 3.6.1: duty 0 -> 100 -> 0 % in 20 % steps (generator open); "
               "step length paper-silent: 30 s, as the bundled recordings"),
        _steps("load", 25.0, [(0.8, k) for k in LOAD_SEQUENCE],
               "paper 3.6.1: 80 % duty, relay-switched 0.5 / 0.01 ohm loads; "
               "sequence and dwell paper-silent: 12 dwells of 25 s, as the bundled recordings"),
        Protocol("long", (Segment(3600.0, 0.8, 2),),
                 "paper 3.6.1: 80 % duty with the 0.01 ohm load; length paper-silent: 60 min"),
        # hpddo's validation protocols (not the paper's; the firmware does not run them)
        _steps("unseen", UNSEEN_STEP_S, UNSEEN_PAIRS,
               "hpddo validation (not in the paper): duty/load pairs that no training "
               "protocol holds, 20 s each so the speed settles, at the bench's ambient",
               role="validation"),
        Protocol("hot", tuple(Segment(s, d, k) for s, d, k in HOT_SEGMENTS),
                 "hpddo validation (not in the paper): the training protocols' duty/load "
                 "pairs on a hot motor, ambient 55 C, after a 20 min warm-up at 80 % duty "
                 "and 0.01 ohm (the long run's pair)",
                 role="validation", ambient_C=HOT_AMBIENT_C),
    )
}

TRAINING_PROTOCOLS = tuple(n for n, p in PROTOCOLS.items() if p.role == "train")
VALIDATION_PROTOCOLS = tuple(n for n, p in PROTOCOLS.items() if p.role == "validation")


def training_pairs() -> set:
    """Every (duty, load) pair some training protocol holds."""
    return {(s.duty, s.load) for n in TRAINING_PROTOCOLS for s in PROTOCOLS[n].segments}


@dataclasses.dataclass(frozen=True)
class BenchHardware:
    """The bench's hardware constants (units in the names)."""

    cpu_hz: int = 16_000_000  # Arduino UNO R3 (paper App. A item 1)
    supply_V: float = 12.0  # paper: 12 V gear motors
    # PWM: paper-silent; the UNO's analogWrite default on D9 (16 MHz / 64 / 510), which the
    # bundled recordings simulate. The firmware sets whole Hz: the nearest, 490 Hz.
    pwm_hz: float = 490.196
    # Motor 25GA371 1:4.4 (paper App. A item 6); encoder on the motor shaft, 11 pulses
    # per motor revolution in quadrature (paper-silent: as the bundled recordings).
    gear_ratio: float = 4.4
    # Commutation ripples per motor revolution: 2 x the commutator's segments for two brushes,
    # a 3-segment rotor (paper-silent: the twin's motor and the UNO's ripple counter's default;
    # the user's figure on the host, hpddo ripple --ripples-per-rev, docs/ripple.md).
    ripples_per_rev: int = 6
    encoder_ppr: int = 11
    encoder_quadrature: int = 4
    # ADC: the UNO's 10-bit ADC on AVcc (paper 3.4), free running at 16 MHz / 128 / 13.
    adc_bits: int = 10
    adc_ref_V: float = 5.0
    adc_conv_per_s: float = 9615.0
    # Voltage: a passive resistive divider (paper 3.5: no bias, no amplifier), 20k
    # (2 x 10k) over 10k from the BOM's 10k resistors: ratio 3, no level shift.
    divider_top_ohm: float = 20_000.0
    divider_bottom_ohm: float = 10_000.0
    v_shift_V: float = 0.0
    # Current: the 0.5 ohm 10 W shunt (paper App. A item 5) straight into the ADC.
    shunt_ohm: float = 0.5
    shunt_gain: float = 1.0
    # Loads: relay-switched resistors on the generator (paper 3.6.1, App. A 12-13).
    load_ohm: tuple = (float("inf"), 0.5, 0.01)
    sample_rate_hz: float = 2.0  # paper 3.6.7: 2 Hz

    @property
    def divider_ratio(self) -> float:
        return (self.divider_top_ohm + self.divider_bottom_ohm) / self.divider_bottom_ohm

    @property
    def v_gain(self) -> float:
        """ADC pin volts per motor-terminal volt."""
        return 1.0 / self.divider_ratio

    @property
    def counts_per_motor_rev(self) -> int:
        return self.encoder_ppr * self.encoder_quadrature

    @property
    def counts_per_output_rev(self) -> float:
        return self.counts_per_motor_rev * self.gear_ratio

    @property
    def pwm_hz_whole(self) -> int:
        """The firmware's PWM setting (the ``pwm`` command takes whole Hz)."""
        return int(round(self.pwm_hz))


HARDWARE = BenchHardware()

# The twin's measurement chain differs from the paper's bench here; the bundled
# recordings (data/default) were made with these values. Follow-up: regenerate the
# bundled data with the paper's passive divider and drop the override.
TWIN_OVERRIDES = {
    "v_div_gain": (0.30, "divider + level shift, ADC = 0.30 (v + 1.5 V); paper 3.5: passive "
                         "divider, no bias (declared: 1/3, no shift)"),
    "v_shift_V": (1.5, "see v_div_gain"),
}


# ------------------------------------------------------------------ the C header
def _c_float(x: float) -> str:
    s = repr(round(float(x), 9))
    if "e" not in s and "." not in s:
        s += ".0"
    return s + "f"


def _q(duty: float) -> int:
    return int(round(duty * 10000))


def header_text() -> str:
    """The generated C/C++ header (C macros, and C++ constants in namespace acq::bench)."""
    h = HARDWARE
    sweep, load, lng = PROTOCOLS["sweep"], PROTOCOLS["load"], PROTOCOLS["long"]
    if len({s.duty for s in load.segments}) != 1 or len(lng.segments) != 1:
        raise ValueError("the firmware's load protocol needs one duty, long one segment")
    if any(s.load for s in sweep.segments):
        raise ValueError("the firmware's sweep runs without load")
    body = []
    w = body.append
    w("#define HPDDO_BENCH_CPU_HZ %dUL" % h.cpu_hz)
    w("#define HPDDO_BENCH_PWM_HZ %dUL  /* whole Hz nearest to %r Hz */" % (h.pwm_hz_whole, h.pwm_hz))
    w("#define HPDDO_BENCH_SAMPLE_RATE_HZ %s" % _c_float(h.sample_rate_hz))
    w("#define HPDDO_BENCH_ADC_BITS %d" % h.adc_bits)
    w("#define HPDDO_BENCH_ADC_REF_V %s" % _c_float(h.adc_ref_V))
    w("#define HPDDO_BENCH_DIVIDER_RATIO %s  /* (%g + %g) / %g ohm */" % (
        _c_float(h.divider_ratio), h.divider_top_ohm, h.divider_bottom_ohm, h.divider_bottom_ohm))
    w("#define HPDDO_BENCH_SHUNT_OHM %s" % _c_float(h.shunt_ohm))
    w("#define HPDDO_BENCH_SHUNT_GAIN %s" % _c_float(h.shunt_gain))
    w("#define HPDDO_BENCH_ENCODER_COUNTS_PER_MOTOR_REV %d  /* %d pulses x %d */" % (
        h.counts_per_motor_rev, h.encoder_ppr, h.encoder_quadrature))
    w("#define HPDDO_BENCH_GEAR_RATIO %s" % _c_float(h.gear_ratio))
    w("#define HPDDO_BENCH_ENCODER_COUNTS_PER_REV %s  /* output shaft */" % _c_float(h.counts_per_output_rev))
    w("#define HPDDO_BENCH_RIPPLES_PER_REV %d  /* commutation ripples per motor revolution */" % h.ripples_per_rev)
    w("#define HPDDO_BENCH_SWEEP_STEPS %d" % len(sweep.segments))
    w("#define HPDDO_BENCH_SWEEP_STEP_S %s" % _c_float(sweep.step_s()))
    w("#define HPDDO_BENCH_LOAD_STEPS %d" % len(load.segments))
    w("#define HPDDO_BENCH_LOAD_STEP_S %s" % _c_float(load.step_s()))
    w("#define HPDDO_BENCH_LOAD_DUTY_Q %d" % _q(load.segments[0].duty))
    w("#define HPDDO_BENCH_LONG_S %s" % _c_float(lng.segments[0].duration_s))
    w("#define HPDDO_BENCH_LONG_DUTY_Q %d" % _q(lng.segments[0].duty))
    w("#define HPDDO_BENCH_LONG_LOAD %d" % lng.segments[0].load)
    w("")
    w("#ifdef __cplusplus")
    w("#include <stdint.h>")
    w("namespace acq {")
    w("namespace bench {")
    w("/// Sweep duty of each step, 0..10000 = 0..1 (generator open).")
    w("static const uint16_t kSweepDutyQ[HPDDO_BENCH_SWEEP_STEPS] = {%s};" % ", ".join(
        str(_q(s.duty)) for s in sweep.segments))
    w("/// Load of each step of the load protocol (0 open, 1 = %g ohm, 2 = %g ohm)." % (
        h.load_ohm[1], h.load_ohm[2]))
    w("static const uint8_t kLoadSequence[HPDDO_BENCH_LOAD_STEPS] = {%s};" % ", ".join(
        str(s.load) for s in load.segments))
    w("}  // namespace bench")
    w("}  // namespace acq")
    w("#endif")
    text = "\n".join(body) + "\n"
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    head = [
        "/* DO NOT EDIT: generated by `python -m hpddo.bench --write` (PYTHONPATH=tools)",
        " * from tools/hpddo/bench.py, the one description of the bench (docs/firmware.md,",
        " * 'The bench'). Edit bench.py and regenerate; test/py/test_bench_description.py",
        " * fails when this file and bench.py disagree.",
        " * sha256 of the body below: %s" % digest,
        " */",
        "#ifndef HPDDO_BENCH_GEN_H",
        "#define HPDDO_BENCH_GEN_H",
        "",
    ]
    return "\n".join(head) + "\n" + text + "\n#endif  /* HPDDO_BENCH_GEN_H */\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m hpddo.bench",
                                 description="Generate uno_acq/bench_gen.h from the bench description.")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--write", action="store_true", help="write the header (default: print it)")
    g.add_argument("--check", action="store_true", help="exit 1 if the header differs from bench.py")
    ap.add_argument("--out", type=pathlib.Path, default=HEADER)
    a = ap.parse_args(argv)
    text = header_text()
    if a.check:
        ok = a.out.exists() and a.out.read_bytes() == text.encode()
        print(f"{a.out}: {'up to date' if ok else 'differs from tools/hpddo/bench.py'}")
        return 0 if ok else 1
    if a.write:
        a.out.write_bytes(text.encode())
        print(f"wrote {a.out}")
        return 0
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
