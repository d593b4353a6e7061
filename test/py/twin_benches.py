"""Twin recordings for the diagnosis tests: a bench of the `ideal` preset with effects
(twin units), forms and parameters of its own, and its recordings at 2 Hz, written once
per folder and seed in a test session."""
import dataclasses

from hpddo.twin import generate, params

TRAINING = ("sweep", "load", "long")
_written = {}


def bench(effects=None, forms=None, **overrides):
    """The ideal bench with the given effects, forms (params.FORMS) and parameters."""
    b = params.with_effects(params.preset("ideal"), **(effects or {}))
    b = params.with_forms(b, **(forms or {}))
    return dataclasses.replace(b, **overrides)


def recordings(out_dir, b, seed, protocols=TRAINING) -> list:
    """The bench log of each protocol of bench b (seed), written into out_dir once."""
    key = (str(out_dir), seed, tuple(protocols))
    if key not in _written:
        for prot in protocols:
            generate.generate(b, prot, 2.0, seed, out_dir=out_dir, preset_name="ideal")
        _written[key] = [out_dir / f"{p}.csv" for p in protocols]
    return _written[key]
