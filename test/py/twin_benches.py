"""Twin recordings for the diagnosis tests: a bench of the `ideal` preset with effects
(twin units), forms and parameters of its own, and its recordings at 2 Hz, written once
per folder and seed in a test session."""
import dataclasses
import math
import pathlib

import numpy as np

from hpddo.twin import generate, params

TRAINING = ("sweep", "load", "long")


def alternating(keys, seeds) -> list:
    """[(key, seed), ...]: each key of a family of cases on one of the seeds, in turn, so that every
    seed is drawn across the family while each case is diagnosed once (the suite's time: the
    property across many draws is the calibration studies', docs/diagnosis-limits.md)."""
    return [(k, seeds[n % len(seeds)]) for n, k in enumerate(keys)]


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


RA_OHM = 4.5          # the dyno tables' motor
KE_VS_PER_RAD = 0.4


def dyno_table(path, rows: int, seed: int = 3, brush_V: float = 0.0, i_A=None, meta=()):
    """A steady-state table in the bench log format (docs/bench-log.md): one row per
    operating point, voltage steps of a sweep and rising load current at each (or the
    current i_A on every row: a current channel that says nothing of the load), t_s one
    second apart, speed (V - I Ra - brush_V) / Ke with tachometer noise, no temperature;
    the reading ra_ohm=RA_OHM and the metadata lines meta ("key=value") in the header."""
    rng = np.random.default_rng(seed)
    volts = np.linspace(3.0, 12.0, 6)
    lines = [f"# condition=dyno{rows}", f"# ra_ohm={RA_OHM}", *(f"# {m}" for m in meta), "t_s,duty,v_V,i_A,rpm_ref"]
    for k in range(rows):
        v = volts[k * len(volts) // rows]
        step = k % math.ceil(rows / len(volts))
        i = 0.1 + 0.02 * step
        rpm = (v - i * RA_OHM - brush_V) / KE_VS_PER_RAD * 60.0 / (2.0 * math.pi)
        i_log = i + rng.normal(0, 0.002) if i_A is None else i_A
        lines.append(f"{k:.1f},{v / 12.0:.3f},{v + rng.normal(0, 0.01):.4f},{i_log:.4f},"
                     f"{rpm + rng.normal(0, 2.0):.2f}")
    path.write_text("\n".join(lines) + "\n")
    return path


_diagnosed = {}


def diagnosed(paths) -> dict:
    """The diagnosis of paths as its JSON, without bootstrap or hybrid (the tests' quick form); a
    copy of the one already made in this test process where the files are the same (path, size and
    modification time): several tests read one bench's diagnosis."""
    import copy
    from hpddo.diagnosis import core
    key = tuple((str(p), p.stat().st_size, p.stat().st_mtime_ns) for p in map(pathlib.Path, paths))
    if key not in _diagnosed:
        _diagnosed[key] = core.diagnose(paths, core.Options(bootstrap=0, hybrid=False)).to_json()
    return copy.deepcopy(_diagnosed[key])
