"""Any valid burst file, no traceback (issue 33, item 4): Hypothesis writes burst files of every
shape the format allows (docs/bench-log.md, Ripple bursts; docs/ripple-captures.md): no rows,
empty bursts, one sample, constant codes, huge and tiny offsets and scales, signed codes,
synchronous and free-running sampling with and without pwm_hz (0, the sample rate, odd ones),
mains declared or not, AC or DC coupling, contiguous bursts or gaps. Each goes through the reader
and `hpddo ripple`, alone (a current-only capture, with and without a speed range) and beside a
bench log (the back-EMF prior, Ke calibrated from the ripple, the gear ratio checked against an
encoder): every run ends in a result (status 0) or a user error (status 1, one line), never an
exception."""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from hpddo import cli
from hpddo.logs import benchlog
from hpddo.logs import ripple as rf
from hpddo.logs.errors import USER_ERRORS

pytestmark = pytest.mark.slow

SHAPES = ("constant", "noise", "ripple", "ripple and pwm", "huge", "alternating")


@st.composite
def burst_spec(draw):
    return {
        "windows": draw(st.integers(min_value=0, max_value=4)),
        "n": draw(st.sampled_from((0, 1, 2, 17, 300, 1200))),
        "shape": draw(st.sampled_from(SHAPES)),
        "sample_hz": draw(st.sampled_from((1.0, 100.0, 4800.0, 9600.0, 1e6))),
        "a_per_code": draw(st.sampled_from((1e-9, 0.0097, 1.0, 1e3))),
        "offset": draw(st.sampled_from((None, 0.0, -3.5, 1e12, 1e-9, 2048.0))),
        "sampling": draw(st.sampled_from((None, "synchronous", "free"))),
        "pwm_hz": draw(st.sampled_from((None, 0.0, 490.196, "fs", 1e-3, 1e9))),
        "mains_hz": draw(st.sampled_from((None, 50.0, 60.0, 1e-3, 0.0))),
        "coupling": draw(st.sampled_from((None, "dc", "ac"))),
        "gaps": draw(st.booleans()),
        "varying_n": draw(st.booleans()),
        "seed": draw(st.integers(min_value=0, max_value=2 ** 16)),
    }


def write_bursts(path, s):
    rng = np.random.default_rng(s["seed"])
    fs = s["sample_hz"]
    meta = {"condition": "any", "sample_hz": repr(fs), "a_per_code": repr(s["a_per_code"])}
    if s["offset"] is not None:
        meta["offset_code"] = repr(s["offset"])
    if s["sampling"] is not None:
        meta["sampling"] = s["sampling"]
    if s["pwm_hz"] is not None:
        meta["pwm_hz"] = repr(fs if s["pwm_hz"] == "fs" else s["pwm_hz"])
    if s["mains_hz"] is not None:
        meta["mains_hz"] = repr(s["mains_hz"])
    if s["coupling"] is not None:
        meta["coupling"] = s["coupling"]
    codes, t_s, t = [], [], 0.0
    for k in range(s["windows"]):
        n = int(s["n"] if not s["varying_n"] else rng.integers(0, s["n"] + 1))
        i = np.arange(n)
        shape = s["shape"]
        if shape == "constant":
            c = np.full(n, 512)
        elif shape == "noise":
            c = 512 + np.round(rng.normal(0, 3, n))
        elif shape == "ripple":
            c = 512 + np.round(40 * np.cos(2 * math.pi * 0.013 * i * (1 + 0.1 * k)) + rng.normal(0, 1, n))
        elif shape == "ripple and pwm":
            c = (300 + 400 * ((i * 490.196 / fs) % 1.0 < 0.3) + np.round(30 * np.cos(2 * math.pi * 0.011 * i)))
        elif shape == "huge":
            c = rng.integers(-2 ** 40, 2 ** 40, n)
        else:
            c = np.where(i % 2 == 0, -1, 1)
        codes.append(np.asarray(c, np.int64))
        t_s.append(t)
        t += n / fs + (rng.uniform(0.5, 2.0) if s["gaps"] else 0.0) + (1e-3 if n == 0 else 0.0)
    return rf.write(path, meta, range(s["windows"]), t_s, codes), t_s


def write_log(path, s, t_s):
    """A bench log whose rows are the bursts' windows (seq 0..), with an encoder."""
    rng = np.random.default_rng(s["seed"] + 1)
    n = s["windows"]
    rows = [f"{k},{t_s[k] if k == 0 else max(t_s[k], t_s[k - 1] + 1e-6):.9g},{0.6 if k % 3 else 0.0},"
            f"{6 + rng.normal(0, 0.1):.4f},{0.3 + rng.normal(0, 0.01):.4f},{100 + rng.normal(0, 1):.3f}"
            for k in range(n)]
    # t_s must increase in the log too: successive burst starts do
    text = "# condition=any\n# ra_ohm=4.5\nseq,t_s,duty,v_V,i_A,rpm_ref\n" + "".join(r + "\n" for r in rows)
    benchlog.write_text_atomic(path, text)
    return path


@settings(max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                   HealthCheck.too_slow])
@given(s=burst_spec())
# 17 samples at 1 Hz: no frequency between the count's band edges (2 / T or 0.5 Hz, and fs / 4.4); it
# was a traceback (argmax of an empty band), found by this test
@example(s={"windows": 1, "n": 17, "shape": "constant", "sample_hz": 1.0, "a_per_code": 0.0097, "offset": None,
            "sampling": None, "pwm_hz": None, "mains_hz": None, "coupling": None, "gaps": False,
            "varying_n": False, "seed": 0})
# a mains frequency of 1 mHz: its multiples up to fs / 2 were listed (5e8 of them: the memory ran out)
@example(s={"windows": 4, "n": 300, "shape": "constant", "sample_hz": 1e6, "a_per_code": 1.0, "offset": 1e12,
            "sampling": None, "pwm_hz": None, "mains_hz": 0.001, "coupling": None, "gaps": True,
            "varying_n": False, "seed": 0})
# 17 samples at 100 Hz, AC-coupled: a line found, too few samples for the count's band-pass (sosfiltfilt)
@example(s={"windows": 1, "n": 17, "shape": "ripple", "sample_hz": 100.0, "a_per_code": 1e-9, "offset": None,
            "sampling": None, "pwm_hz": None, "mains_hz": None, "coupling": "ac", "gaps": False,
            "varying_n": False, "seed": 1})
# a 1 mHz mains again, AC-coupled ripple in two windows: every mains multiple near each line was listed, 311 s
@example(s={"windows": 2, "n": 17, "shape": "ripple", "sample_hz": 1e6, "a_per_code": 0.0097, "offset": 1e12,
            "sampling": None, "pwm_hz": 0.0, "mains_hz": 0.001, "coupling": "ac", "gaps": True,
            "varying_n": False, "seed": 526})
def test_any_valid_burst_file_gives_a_result_or_a_user_error(tmp_path_factory, s):
    d = tmp_path_factory.mktemp("burst")
    path, t_s = write_bursts(d / "any.ripple.csv", s)
    try:
        b = rf.read(path)
    except USER_ERRORS as exc:
        event(f"refused by the reader: {str(exc).split(': ', 1)[-1][:40]}")
        return
    assert len(b) == s["windows"]
    common = ["--ripples-per-rev", "6", "--gear-ratio", "4.4", "--quiet"]
    for more in ([], ["--rpm-range", "10", "500"]):
        status = cli.main(["ripple", str(path), *common, "--out", str(d / f"capture{len(more)}"), *more])
        assert status in (0, 1)
        event(f"capture: status {status}")
    if s["windows"]:
        log = write_log(d / "any.csv", s, t_s)
        status = cli.main(["ripple", str(log), *common, "--out", str(d / "logged")])
        assert status in (0, 1)
        event(f"beside a log: status {status}")


@st.composite
def coast_spec(draw):
    return {
        "burst": draw(burst_spec()),
        "probes": draw(st.integers(min_value=0, max_value=4)),
        "n_i": draw(st.sampled_from((0, 1, 3, 20, 200))),
        "n_v": draw(st.sampled_from((0, 1, 3, 20, 200))),
        "shape": draw(st.sampled_from(("decay", "constant", "noise", "huge", "negative"))),
        "sample_hz": draw(st.sampled_from((1.0, 10000.0, 1e6))),
        "v_per_code": draw(st.sampled_from((1e-9, 0.0147, 1e3))),
        "v_shift": draw(st.sampled_from((None, 0.0, 1.5, -1e9))),
        "seed": draw(st.integers(min_value=0, max_value=2 ** 16)),
    }


def write_coast(path, c, t_s):
    """Probes at some of the log's rows (seq), each a burst of both channels."""
    from hpddo.logs import coast as cf
    rng = np.random.default_rng(c["seed"])
    rows = sorted(set(rng.integers(0, len(t_s), c["probes"]).tolist())) if len(t_s) else []
    ic, vc = [], []
    for _ in rows:
        j_i, j_v = np.arange(c["n_i"]), np.arange(c["n_v"])
        if c["shape"] == "decay":
            i, v = np.maximum(0, 60 - 20 * j_i), np.full(c["n_v"], 300)
        elif c["shape"] == "constant":
            i, v = np.full(c["n_i"], 7), np.full(c["n_v"], 7)
        elif c["shape"] == "noise":
            i, v = np.round(rng.normal(0, 3, c["n_i"])), np.round(300 + rng.normal(0, 3, c["n_v"]))
        elif c["shape"] == "huge":
            i, v = rng.integers(-2 ** 40, 2 ** 40, c["n_i"]), rng.integers(-2 ** 40, 2 ** 40, c["n_v"])
        else:
            i, v = -np.abs(60 - 20 * j_i), -np.full(c["n_v"], 300)
        ic.append(np.asarray(i, np.int64))
        vc.append(np.asarray(v, np.int64))
    probes = cf.ProbeBursts(sample_hz=c["sample_hz"], a_per_code=0.0097, v_per_code=c["v_per_code"],
                            v_shift_V=0.0 if c["v_shift"] is None else c["v_shift"], seq=np.array(rows, np.int64),
                            t_s=np.array([t_s[r] for r in rows], float), i_codes=ic, v_codes=vc)
    return cf.write(path, probes, {"condition": "any"})


@settings(max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                   HealthCheck.too_slow])
@given(c=coast_spec())
def test_any_valid_coast_file_gives_a_result_or_a_user_error(tmp_path_factory, c):
    """`hpddo ripple --coast` on a log, its bursts and its probes of every shape: status 0 or 1."""
    s = c["burst"]
    d = tmp_path_factory.mktemp("coast")
    path, t_s = write_bursts(d / "any.ripple.csv", s)
    log = write_log(d / "any.csv", s, t_s)
    write_coast(d / "any.coast.csv", c, [float(t) for t in benchlog.read_log(log).df["t_s"]] if s["windows"] else [])
    status = cli.main(["ripple", str(log), "--coast", "--ripples-per-rev", "6", "--gear-ratio", "4.4",
                       "--ke-vs-per-rad", "0.35", "--quiet", "--out", str(d / "out")])
    assert status in (0, 1)
    event(f"coast: status {status}")
