"""Any capture, no traceback (issues 31 item 1 and 33): Hypothesis writes current captures of every
shape a scope, a DAQ, a sound card or MATLAB gives (docs/ripple-captures.md): CSV with or without a
header and a time column (s or ms), any separator, CRLF, blank lines at the end; WAV of 8/16/32-bit
PCM or float, one to three channels, any rate; .mat vectors as rows or columns, integer or float,
with or without a rate variable; values constant, noisy, rippled, alternating, tiny or huge, a few
samples to thousands. `hpddo import` must end in a burst file (status 0) or a user error (status 1,
one line, no file written), and `hpddo ripple` on what it wrote in a result or a user error: never an
exception. Where the import succeeds, the burst file holds every sample, as the value it was to
within the code's step."""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from hpddo import cli
from hpddo.logs import ripple as rf

pytestmark = pytest.mark.slow

SHAPES = ("constant", "noise", "ripple", "alternating", "steps")


@st.composite
def capture_spec(draw):
    kind = draw(st.sampled_from(("csv", "wav", "mat")))
    return {
        "kind": kind,
        "n": draw(st.sampled_from((0, 1, 15, 16, 17, 300, 5000))),
        "shape": draw(st.sampled_from(SHAPES)),
        "scale": draw(st.sampled_from((1e-300, 1e-9, 1e-3, 1.0, 1e3, 1e12, 1e300))),
        "offset": draw(st.sampled_from((0.0, -7.5, 1e6))),
        "integer": draw(st.booleans()),
        "sample_hz": draw(st.sampled_from((1.0, 100.0, 9600.0, 44100.0, 1e6))),
        "give_hz": draw(st.booleans()),
        # csv
        "header": draw(st.booleans()),
        "time": draw(st.sampled_from((None, "s", "ms"))),
        "sep": draw(st.sampled_from((",", ";", "\t", " "))),
        "crlf": draw(st.booleans()),
        "trailing_blank": draw(st.booleans()),
        # wav
        "wav_dtype": draw(st.sampled_from(("uint8", "int16", "int32", "float32", "float64"))),
        "channels": draw(st.integers(min_value=1, max_value=3)),
        # mat
        "mat_shape": draw(st.sampled_from(("row", "column", "flat"))),
        "mat_rate": draw(st.sampled_from((None, "fs", "sample_hz"))),
        "mat_format": draw(st.sampled_from(("5", "4"))),
        # import and count
        "window_s": draw(st.sampled_from((1e-3, 0.05, 0.5, 1e4))),
        "pwm_hz": draw(st.sampled_from((0.0, 490.196, 1e9))),
        "mains_hz": draw(st.sampled_from((None, 50.0, 1e-3, 0.0))),
        "coupling": draw(st.sampled_from((None, "dc", "ac"))),
        "seed": draw(st.integers(min_value=0, max_value=2 ** 16)),
    }


def values_of(s):
    rng = np.random.default_rng(s["seed"])
    n, i = s["n"], np.arange(s["n"])
    shape = s["shape"]
    if shape == "constant":
        x = np.ones(n)
    elif shape == "noise":
        x = rng.normal(0.0, 1.0, n)
    elif shape == "ripple":
        x = 1.0 + 0.2 * np.cos(2 * math.pi * 0.013 * i) + rng.normal(0, 0.01, n)
    elif shape == "alternating":
        x = np.where(i % 2 == 0, -1.0, 1.0)
    else:
        x = np.floor(i / max(1, n // 5)).astype(float)
    return s["offset"] + s["scale"] * x


def write_capture(d, s):
    """The capture file, the import flags it needs beside the common ones, and the values written."""
    x = values_of(s)
    fs = s["sample_hz"]
    flags = ["--sample-hz", repr(fs)] if s["give_hz"] else []
    if s["kind"] == "csv":
        if s["integer"]:
            x = np.clip(np.round(x), -2.0 ** 53, 2.0 ** 53)
        cols = [x]
        names = ["i_A"]
        if s["time"] is not None:
            cols.insert(0, np.arange(len(x)) / fs * (1e3 if s["time"] == "ms" else 1.0))
            names.insert(0, "time_ms" if s["time"] == "ms" else "t_s")
        fmt = (lambda v: f"{v:.0f}") if s["integer"] else repr
        lines = ([s["sep"].join(names)] if s["header"] else []) + [
            s["sep"].join([repr(float(c[k])) for c in cols[:-1]] + [fmt(float(x[k]))]) for k in range(len(x))]
        nl = "\r\n" if s["crlf"] else "\n"
        text = nl.join(lines) + nl + (nl * 2 if s["trailing_blank"] else "")
        p = d / "cap.csv"
        p.write_bytes(text.encode())
        if s["time"] is not None and s["header"]:
            flags = flags if s["give_hz"] else []
        elif s["time"] is not None:
            flags += ["--column", "1", "--time-column", "0"]
        return p, flags, x
    if s["kind"] == "wav":
        from scipy.io import wavfile
        dt = np.dtype(s["wav_dtype"])
        if np.issubdtype(dt, np.integer):
            info = np.iinfo(dt)
            y = np.clip(np.nan_to_num(x / max(np.abs(x).max(), 1e-300) * info.max if len(x) else x),
                        info.min, info.max).astype(dt)
        else:
            y = np.clip(x, -np.finfo(dt).max, np.finfo(dt).max).astype(dt)
        y = np.repeat(y[:, None], s["channels"], axis=1) if s["channels"] > 1 else y
        p = d / "cap.wav"
        wavfile.write(p, max(1, int(fs)), y)
        return p, flags + (["--channel", str(s["channels"] - 1)] if s["channels"] > 1 else []), \
            np.asarray(y if y.ndim == 1 else y[:, 0], float)
    from scipy.io import savemat
    y = np.round(np.clip(x, -2.0 ** 31, 2.0 ** 31 - 1)).astype(np.int32) if s["integer"] else x
    y = y[None, :] if s["mat_shape"] == "row" else y[:, None] if s["mat_shape"] == "column" else y
    data = {"current": y}
    if s["mat_rate"] is not None:
        data[s["mat_rate"]] = fs
    p = d / "cap.mat"
    savemat(p, data, format=s["mat_format"])
    return p, flags + ["--variable", "current"], np.asarray(y, float).ravel()


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(s=capture_spec())
def test_any_capture_imports_and_counts_to_a_result_or_a_user_error(tmp_path_factory, s, capsys):
    d = tmp_path_factory.mktemp("capture")
    path, flags, x = write_capture(d, s)
    out = d / "cap.ripple.csv"
    more = ["--window-s", repr(s["window_s"]), "--pwm-hz", repr(s["pwm_hz"])]
    more += ["--mains-hz", repr(s["mains_hz"])] if s["mains_hz"] is not None else []
    more += ["--coupling", s["coupling"]] if s["coupling"] else []
    status = cli.main(["import", str(path), "--a-per-unit", "0.01", "--out", str(out), "--quiet", *flags, *more])
    err = capsys.readouterr().err
    assert status in (0, 1), (status, err)
    if status == 1:
        event(f"import refused: {err.split(': ')[-1][:40]}")
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
        assert not out.exists(), "a refused import left a burst file"
        return
    b = rf.read(out)
    event(f"imported: {len(b)} windows")
    codes = np.concatenate([np.asarray(c, float) for c in b.codes]) if len(b) else np.zeros(0)
    # what the file says each sample was, in the capture's units: code x step (a_per_code = a_per_unit x step)
    step = b.a_per_code / 0.01
    assert 0 < len(codes) <= len(x)
    assert np.all(np.abs(codes * step - x[:len(codes)]) <= 0.5000001 * step + 1e-12 * np.abs(x[:len(codes)])), \
        "the burst file does not hold the capture's values"
    for more_args in ([], ["--rpm-range", "10", "500"]):
        status = cli.main(["ripple", str(out), "--ripples-per-rev", "6", "--gear-ratio", "4.4", "--quiet",
                           "--out", str(d / f"speed{len(more_args)}"), *more_args])
        err = capsys.readouterr().err
        assert status in (0, 1) and "Traceback" not in err, (status, err)
        event(f"ripple: status {status}")
