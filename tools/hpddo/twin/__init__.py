"""Bench twin: a physical simulator of the paper's PMDC test bench that writes bench logs.

See docs/twin.md. Entry points: `generate.generate` (one recording) and tools/twin.py (CLI);
the ripple mode's current bursts in `ripple` (docs/ripple-counting.md, "The twin's ripple mode").

May import: the foundations (hpddo.schema, hpddo.bench), hpddo.logs, hpddo.model (its
float32 libm) and hpddo.ripple; not hpddo.evaluation, which stands beside it.
"""
from .params import EFFECT_NAMES, EFFECTS, GENERATOR_VERSION, Bench, preset, with_effects  # noqa: F401
