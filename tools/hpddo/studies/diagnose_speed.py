"""How long the diagnosis takes with its defaults (hpddo bench --diagnose).

The bundled recordings (data/default: three recordings, 8,465 rows) are diagnosed as `hpddo
diagnose` does with its defaults (the bootstrap's resamples and the hybrid retrained before and
after), and the parts are timed in the same run, so that the figures carry their peer: one fit
of M2 with every effect of the library on the same rows (core.fit_model), the unit every step of
the diagnosis is made of. The ratio of the two says how many such fits the diagnosis costs,
which does not depend on the machine; the seconds do.

The target (calibration issue, item 8): at most 10 s on an idle 2-core machine. The figure the
issue measured before any work on speed: 31 s for a three-recording bench of 13.6k rows on an
idle 2-core machine (116 s with the other core busy).
"""
from __future__ import annotations

import pathlib
import time

TARGET_S = 10.0


def measure(data: pathlib.Path) -> dict:
    """Seconds of the default diagnosis of the logs in data, of its physics verdict alone (no
    bootstrap, no hybrid), and of one full-library fit (the peer), measured in this process."""
    from ..diagnosis import core
    from ..logs.errors import InputError

    logs = sorted(p for p in pathlib.Path(data).glob("*.csv") if not p.name.endswith(".truth.csv"))
    if not logs:
        raise InputError(f"no bench logs (*.csv) in {data}")
    t0 = time.perf_counter()
    inp = core.load(logs, core.Options())
    core.fit_model(inp)
    peer_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    core.diagnose(logs, core.Options(bootstrap=0, hybrid=False))
    physics_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    core.diagnose(logs, core.Options())
    default_s = time.perf_counter() - t0
    rows = sum(r.rec.n for r in inp.rows)
    return {"recordings": len(logs), "rows": rows, "default_s": default_s, "physics_s": physics_s,
            "peer_fit_s": peer_s, "default_over_peer": default_s / peer_s, "physics_over_peer": physics_s / peer_s}


def report(m: dict) -> str:
    from ..diagnosis.ranking import BOOTSTRAP
    return "\n".join([
        f"diagnosis of {m['recordings']} recordings, {m['rows']} rows (data/default):",
        f"  with the defaults (bootstrap {BOOTSTRAP}, hybrid before and after): "
        f"{m['default_s']:.1f} s (target {TARGET_S:g} s on an idle 2-core machine: "
        f"{'met' if m['default_s'] <= TARGET_S else 'NOT met'} on this machine as loaded now)",
        f"  the physics verdict alone (--bootstrap 0 --no-hybrid): {m['physics_s']:.1f} s",
        f"  peer: one fit of M2 with every library effect on the same rows: {m['peer_fit_s']:.2f} s",
        f"  ratios (machine-independent): defaults / peer {m['default_over_peer']:.0f}, "
        f"physics verdict / peer {m['physics_over_peer']:.0f}",
    ])
