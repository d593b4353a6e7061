"""Valid bench logs of every shape (docs/bench-log.md), for the property tests that every tool
gives a result or a user error on them: channels constant, stuck, clipped, coarse or noisy; one
operating point per log or per row; tables with and without `kind`; duplicated rows; motors
from milliamps to kiloamps-scale (test_any_valid_log.py, test_any_valid_log_tools.py)."""
import math
import pathlib
import re

import numpy as np
from hypothesis import strategies as st

# the shapes a channel may take (besides following the motor)
V_SHAPES = ("follows", "fixed supply", "clipped", "coarse")
I_SHAPES = ("follows", "stuck", "clipped", "coarse", "noisy")
DUTY_SHAPES = ("fixed", "sorted steps", "held steps", "per row random")


@st.composite
def log_spec(draw):
    """One recording's shape and numbers."""
    return {
        "rows": draw(st.integers(min_value=3, max_value=160)),
        "duty": draw(st.sampled_from(DUTY_SHAPES)),
        "v": draw(st.sampled_from(V_SHAPES)),
        "i": draw(st.sampled_from(I_SHAPES)),
        "kind": draw(st.sampled_from((None, "steady_state", "time_series"))),
        "rate": draw(st.sampled_from((None, 1.0, 2.0, 100.0))),
        "rpm": draw(st.sampled_from(("all", "some empty", "none"))),
        "temp": draw(st.sampled_from((None, "constant", "rising"))),
        "load": draw(st.booleans()),
        "duplicate": draw(st.booleans()),
        "seed": draw(st.integers(min_value=0, max_value=2 ** 16)),
    }


RA_OHM = 4.5  # the motor's at scale 1


def write_log(path: pathlib.Path, s: dict, k: float = 1.0) -> pathlib.Path:
    """The bench log of spec s at path, a motor of size k (its current 1 / k times, its Ra k
    times the unit motor's): valid by docs/bench-log.md whatever its physics."""
    rng = np.random.default_rng(s["seed"])
    n = s["rows"]
    ra, ke = RA_OHM * k, 0.4
    if s["duty"] == "fixed":
        duty = np.full(n, 0.8)
    elif s["duty"] == "sorted steps":
        duty = np.sort(rng.choice([0.2, 0.4, 0.6, 0.8, 1.0], n))
    elif s["duty"] == "held steps":
        duty = np.repeat(rng.choice([0.0, 0.3, 0.6, 0.9], max(1, n // 5 + 1)), 5)[:n]
    else:
        duty = rng.uniform(0.0, 1.0, n).round(3)
    load = rng.integers(0, 3, n) if s["load"] else np.zeros(n, int)
    v = 12.0 * duty * (1.0 if s["v"] != "fixed supply" else 0.0) + (12.0 if s["v"] == "fixed supply" else 0.0)
    i = (0.1 + 0.3 * load + 0.05 * rng.random(n)) / max(k, 1e-9) * (duty > 0)
    rpm = np.maximum((v - i * ra) / ke, 0.0) * 60 / (2 * math.pi) + rng.normal(0, 1.0, n)
    v = v + rng.normal(0, 0.01, n)
    if s["v"] == "clipped":
        v = np.minimum(v, 7.0)
    if s["v"] == "coarse":
        v = np.round(v / 2.0) * 2.0
    if s["i"] == "stuck":
        i = np.full(n, 0.123)
    elif s["i"] == "clipped":
        i = np.minimum(i, np.percentile(i, 40))
    elif s["i"] == "coarse":
        i = np.round(i / (0.5 / max(k, 1e-9))) * (0.5 / max(k, 1e-9))
    elif s["i"] == "noisy":
        i = i + rng.normal(0, 0.5 / max(k, 1e-9), n)
    rows = np.arange(n)
    if s["duplicate"] and n > 4:  # rows repeated value for value (a new t_s: it must increase)
        rows = np.sort(np.concatenate([rows, rng.choice(n, n // 3)]))
    dt = 1.0 / s["rate"] if s["rate"] else 1.0
    meta = [f"# condition={path.stem}"]
    if s["kind"]:
        meta.append(f"# kind={s['kind']}")
    if s["rate"]:
        meta.append(f"# sample_rate_hz={s['rate']:g}")
    cols = ["t_s", "duty", "v_V", "i_A", "rpm_ref"] + (["temp_C"] if s["temp"] else []) + (["load"] if s["load"] else [])
    lines = meta + [",".join(cols)]
    for t, r in enumerate(rows):
        cell_rpm = "" if s["rpm"] == "none" or (s["rpm"] == "some empty" and r % 3 == 0) else f"{rpm[r]:.6g}"
        row = [f"{t * dt:.6g}", f"{duty[r]:.6g}", f"{v[r]:.6g}", f"{i[r]:.6g}", cell_rpm]
        if s["temp"]:
            row.append(f"{30.0 + (0.0 if s['temp'] == 'constant' else 0.05 * t):.4g}")
        if s["load"]:
            row.append(str(int(load[r])))
        lines.append(",".join(row))
    path.write_text("\n".join(lines) + "\n")
    return path


# words of a Python exception's message that a verdict must never carry
EXCEPTION_TEXT = re.compile(r"out of bounds|zero-size array|has no attribute|object is not|Traceback|"
                            r"division by zero|cannot convert|index \d+ is")
