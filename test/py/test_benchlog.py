"""Bench log reader/writer (docs/bench-log.md): round trip, every named fault, column order and extras."""
import math
import os

import numpy as np
import pandas as pd
import pytest

from hpddo.logs import benchlog
from hpddo.logs.benchlog import BenchLogError, read_log, write_log

GOOD = """\
# condition=sweep
# sample_rate_hz=2
# motor=25GA371 1:4.4
t_s,duty,v_V,i_A,rpm_ref,temp_C,load
0.0,0.000,0.012,0.003,0.0,31.7,0
0.5,0.200,2.391,0.214,41.2,31.7,0
1.0,0.200,2.401,0.210,,,1
"""


def _write(tmp_path, text, name="log.csv", encoding="utf-8"):
    p = tmp_path / name
    p.write_bytes(text.encode(encoding))
    return p


def test_reads_spec_example(tmp_path):
    log = read_log(_write(tmp_path, GOOD))
    assert log.meta == {"condition": "sweep", "sample_rate_hz": "2", "motor": "25GA371 1:4.4"}
    assert log.condition == "sweep"
    assert log.sample_rate_hz == 2.0
    assert list(log.df.columns) == ["t_s", "duty", "v_V", "i_A", "rpm_ref", "temp_C", "load"]
    assert len(log.df) == 3
    assert math.isnan(log.df["rpm_ref"].iloc[2]) and math.isnan(log.df["temp_C"].iloc[2])
    assert log.df["load"].tolist() == [0, 0, 1]
    assert log.df["load"].dtype == np.int64


def test_condition_falls_back_to_stem(tmp_path):
    log = read_log(_write(tmp_path, "t_s,duty,v_V,i_A\n0,0,0,0\n", name="myrun.csv"))
    assert log.condition == "myrun"
    assert "rpm_ref" not in log.df.columns  # absent optional column stays absent


def test_round_trip(tmp_path):
    rng = np.random.default_rng(3)
    n = 500
    df = pd.DataFrame(
        {
            "t_s": np.arange(n) * 0.5,
            "duty": rng.choice([0.0, 0.2, 0.4, 0.8, 1.0], n),
            "v_V": rng.uniform(-0.7, 12, n),
            "i_A": rng.uniform(0, 2, n),
            "rpm_ref": rng.uniform(0, 280, n),
            "temp_C": 31.7 + rng.integers(0, 600, n) * 0.0625,
            "load": rng.integers(0, 3, n),
            "seq": np.arange(n),
        }
    )
    df.loc[7, "rpm_ref"] = np.nan
    meta = {"condition": "rt", "sample_rate_hz": "2", "note": "a, note with = signs"}
    p = write_log(tmp_path / "rt.csv", df, meta)
    log = read_log(p)
    assert log.meta == meta
    assert list(log.df.columns) == list(df.columns)
    for c, tol in [("t_s", 5e-5), ("duty", 5e-5), ("v_V", 5e-7), ("i_A", 5e-7),
                   ("rpm_ref", 5e-4), ("temp_C", 5e-5)]:
        np.testing.assert_allclose(log.df[c], df[c], atol=tol, rtol=0, err_msg=c)
    assert math.isnan(log.df["rpm_ref"].iloc[7])
    assert (log.df["load"].to_numpy() == df["load"].to_numpy()).all()
    # writing what was read gives the same bytes: the formats are a fixed point
    p2 = write_log(tmp_path / "rt2.csv", log.df, log.meta)
    assert p.read_bytes() == p2.read_bytes()
    # no temporary files left behind
    assert sorted(os.listdir(tmp_path)) == ["rt.csv", "rt2.csv"]


def test_other_column_order_and_extra_columns(tmp_path):
    text = "# condition=x\nnote_col,i_A,extra_num,t_s,v_V,duty\nhello,0.1,3,0,1.0,0.5\nworld,0.2,4,1,2.0,0.6\n"
    log = read_log(_write(tmp_path, text))
    assert list(log.df.columns) == ["note_col", "i_A", "extra_num", "t_s", "v_V", "duty"]
    assert log.df["note_col"].tolist() == ["hello", "world"]
    assert log.df["extra_num"].tolist() == [3.0, 4.0]
    assert log.df["duty"].tolist() == [0.5, 0.6]


def test_bom_and_crlf_tolerated(tmp_path):
    text = "\ufeff" + GOOD.replace("\n", "\r\n")
    log = read_log(_write(tmp_path, text))
    assert log.meta["condition"] == "sweep" and len(log.df) == 3


def test_empty_seq_cell_is_refused(tmp_path):
    # a counter with holes cannot be checked for gaps: seq is in every row or absent
    with pytest.raises(BenchLogError) as ei:
        read_log(_write(tmp_path, "t_s,duty,v_V,i_A,seq\n0,0,0,0,1\n1,0,0,0,\n"))
    assert ei.value.line == 3 and ei.value.kind == "empty value"


def test_lines_are_file_lines(tmp_path):
    text = "\ufeff# a=1\r\n# b=2\n" + HDR + ROW0 + "0.5,0.5,6.0,0.3,,31.7,0,1\r\n" + "1.0,0.5,6.0,0.3,1,,0,2"
    log = read_log(_write(tmp_path, text))
    assert log.lines.dtype == np.int64
    assert log.lines.tolist() == [4, 5, 6]
    assert log.df["seq"].dtype == np.int64 and log.df["load"].dtype == np.int64


HDR = "t_s,duty,v_V,i_A,rpm_ref,temp_C,load,seq\n"
ROW0 = "0.0,0.5,6.0,0.3,100.0,31.7,0,0\n"

FAULTS = [
    # (name, text, expected line, words in the message)
    ("empty file", "", 1, "empty file"),
    ("only newlines", "\n\n", 1, "blank line"),
    ("only metadata", "# condition=x\n", 1, "no header"),
    ("header no rows", "# condition=x\n" + HDR, 2, "header with no rows"),
    ("malformed metadata", "# condition=x\n# just words\n" + HDR + ROW0, 2, "malformed metadata"),
    ("metadata empty key", "#=3\n" + HDR + ROW0, 1, "malformed metadata"),
    ("missing column", "t_s,duty,v_V\n0,0,0\n", 1, "missing required column(s) i_A"),
    ("non-numeric required", HDR + ROW0 + "0.5,0.5,abc,0.3,100,31.7,0,1\n", 3, "non-numeric value 'abc' in column v_V"),
    ("empty required", HDR + ROW0 + "0.5,0.5,6.0,,100,31.7,0,1\n", 3, "empty value in required column i_A"),
    ("non-finite required", HDR + ROW0 + "0.5,0.5,inf,0.3,100,31.7,0,1\n", 3, "non-finite value 'inf' in column v_V"),
    ("nan required", HDR + ROW0 + "nan,0.5,6,0.3,100,31.7,0,1\n", 3, "non-finite value 'nan' in column t_s"),
    ("t_s equal", HDR + ROW0 + "0.0,0.5,6,0.3,100,31.7,0,1\n", 3, "t_s not increasing"),
    ("t_s decreasing", HDR + ROW0 + "1.0,0.5,6,0.3,100,31.7,0,1\n0.5,0.5,6,0.3,100,31.7,0,2\n", 4, "t_s not increasing"),
    ("duty > 1", HDR + ROW0 + "0.5,1.2,6,0.3,100,31.7,0,1\n", 3, "duty outside 0..1: 1.2"),
    ("duty < 0", HDR + "0.0,-0.1,6,0.3,100,31.7,0,1\n", 2, "outside 0..1"),
    ("too many fields", HDR + ROW0 + "0.5,0.5,6,0.3,100,31.7,0,1,9\n", 3, "row has 9 fields, header has 8"),
    ("too few fields", HDR + ROW0 + "0.5,0.5,6,0.3\n", 3, "row has 4 fields, header has 8"),
    ("blank line inside", HDR + ROW0 + "\n" + "0.5,0.5,6,0.3,100,31.7,0,1\n", 3, "blank line"),
    ("comment after header", HDR + ROW0 + "# late=1\n", 3, "metadata after header"),
    ("cr inside a row", HDR + ROW0 + "0.5,0.5\r,6,0.3,100,31.7,0,1\n", 3, "carriage return"),
    ("seq beyond int64", HDR + ROW0 + "0.5,0.5,6,0.3,100,31.7,0,99999999999999999999\n", 3, "out of range"),
    ("load beyond int64", HDR + ROW0 + "0.5,0.5,6,0.3,100,31.7,99999999999999999999,1\n", 3, "out of range"),
    ("non-integer load", HDR + ROW0 + "0.5,0.5,6,0.3,100,31.7,1.5,1\n", 3, "non-integer value '1.5' in column load"),
    ("non-integer seq", HDR + ROW0 + "0.5,0.5,6,0.3,100,31.7,1,x\n", 3, "non-integer value 'x' in column seq"),
    ("text in rpm_ref", HDR + ROW0 + "0.5,0.5,6,0.3,fast,31.7,1,1\n", 3, "non-numeric value 'fast' in column rpm_ref"),
    ("text in temp_C", HDR + ROW0 + "0.5,0.5,6,0.3,100,hot,1,1\n", 3, "non-numeric value 'hot' in column temp_C"),
    ("duplicate column", "t_s,duty,v_V,i_A,t_s\n0,0,0,0,0\n", 1, "duplicate column"),
]


@pytest.mark.parametrize("name,text,line,words", FAULTS, ids=[f[0] for f in FAULTS])
def test_faults_are_named(tmp_path, name, text, line, words):
    p = _write(tmp_path, text, name="bad.csv")
    with pytest.raises(BenchLogError) as ei:
        read_log(p)
    msg = str(ei.value)
    assert str(p) in msg
    assert f"{p}:{line}:" in msg, msg
    assert words in msg, msg
    assert ei.value.line == line
    assert isinstance(ei.value, ValueError)


def test_metadata_line_numbers_count(tmp_path):
    # the reported line is the line in the file, metadata and header included
    text = "# a=1\n# b=2\n# c=3\n" + HDR + ROW0 + ROW0.replace("0.0,", "1.0,", 1).replace(",0\n", ",1\n").replace("6.0", "bad")
    p = _write(tmp_path, text)
    with pytest.raises(BenchLogError) as ei:
        read_log(p)
    assert ei.value.line == 6


def test_not_utf8(tmp_path):
    p = tmp_path / "latin.csv"
    p.write_bytes(("# note=caf\xe9\n" + HDR + ROW0).encode("latin-1"))
    with pytest.raises(BenchLogError) as ei:
        read_log(p)
    assert ei.value.line == 1 and "UTF-8" in str(ei.value)


def test_writer_refuses_bad_frames(tmp_path):
    good = pd.DataFrame({"t_s": [0.0, 0.5], "duty": [0.1, 0.2], "v_V": [1.0, 2.0], "i_A": [0.1, 0.1]})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good.drop(columns="i_A"), {})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good.assign(duty=[0.1, 1.5]), {})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good.assign(t_s=[0.5, 0.5]), {})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good, {"note": "two\nlines"})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good, {"my key": "x"})
    # increasing in float, equal once written with COLUMN_FORMATS' 4 decimals: written with the decimals it needs
    fast = write_log(tmp_path / "a.csv", good.assign(t_s=[0.00001, 0.00002]), {})
    assert read_log(fast).df["t_s"].tolist() == [0.00001, 0.00002]
    fast.unlink()
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good.assign(rpm_ref=[1.0, np.inf]), {})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good.assign(seq=pd.array([0, None], dtype="Int64")), {})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good.assign(seq=[0.0, 1.5]), {})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good.assign(load=[0, 256]), {})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good.assign(**{" pad": [1, 2]}), {})
    with pytest.raises(ValueError):
        write_log(tmp_path / "a.csv", good.assign(note=["a,b", "c"]), {})
    assert not any(tmp_path.iterdir())  # nothing written, no temp files


def test_atomic_replace_keeps_old_file_on_failure(tmp_path, monkeypatch):
    df = pd.DataFrame({"t_s": [0.0], "duty": [0.1], "v_V": [1.0], "i_A": [0.1]})
    p = write_log(tmp_path / "a.csv", df, {"condition": "a"})
    before = p.read_bytes()

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError):
        write_log(p, df.assign(v_V=[9.0]), {"condition": "a"})
    assert p.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["a.csv"]


def test_write_bytes_atomic_replaces_whole_or_leaves_the_old_file(tmp_path):
    """The one atomic writer: a reader sees the old file or the whole new one, and a failed
    write leaves the old file and no temporary file behind."""
    target = tmp_path / "f.bin"
    benchlog.write_bytes_atomic(target, b"old")
    assert target.read_bytes() == b"old"

    def fails(fh):
        fh.write(b"half of the new")
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError):
        benchlog.write_bytes_atomic(target, fails)
    assert target.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.bin"]
    benchlog.write_bytes_atomic(target, lambda fh: fh.write(b"streamed"))
    assert target.read_bytes() == b"streamed"
    assert (target.stat().st_mode & 0o777) == 0o644


def test_json_text_writes_what_is_not_finite_as_null():
    """benchlog.json_text, behind every JSON file the tools write (diagnosis.json, metrics.json,
    the ripple's summary.json): a standard error of an effect the rows do not excite (inf), an
    RMSE without encoder rows (NaN) and numpy's numbers, as strict JSON."""
    import json
    import math

    import numpy as np

    obj = {"se": math.inf, "rmse": float("nan"), "np": np.float64(-np.inf), "arr": np.array([1.5, np.nan]),
           "n": np.int64(3), "t": (1, 2.5), "nested": [{"x": -math.inf}]}
    text = benchlog.json_text(obj, indent=1)
    assert text.endswith("\n")
    back = json.loads(text, parse_constant=lambda c: (_ for _ in ()).throw(AssertionError(c)))
    assert back == {"se": None, "rmse": None, "np": None, "arr": [1.5, None], "n": 3, "t": [1, 2.5],
                    "nested": [{"x": None}]}
    finite = {"a": [1, 2.0, "s", None, True]}
    assert benchlog.json_text(finite, indent=1) == json.dumps(finite, indent=1) + "\n"


def test_a_copy_written_exactly_holds_the_numbers_it_was_read_with(tmp_path):
    """write_log(exact=True), the copy of a log the tools write beside their work (dataset.write_clean: the
    native replay's input): every number reads back as the same double. COLUMN_FORMATS' fixed decimals rounded a
    log of microamps to 0.000001 A, and hpddo train's M2 reported 26.38 RPM where the diagnosis of the same
    rows gave 4.09."""
    import numpy as np
    import pandas as pd

    from hpddo.logs import benchlog

    rng = np.random.default_rng(1)
    df = pd.DataFrame({"t_s": np.cumsum(rng.uniform(1e-6, 1e-3, 50)), "duty": rng.uniform(0, 1, 50),
                       "v_V": rng.normal(0, 1, 50) * 1e-6, "i_A": rng.normal(0, 1, 50) * 1e-7,
                       "rpm_ref": rng.normal(100, 30, 50), "temp_C": rng.normal(30, 3, 50)})
    df.loc[3, "rpm_ref"] = float("nan")
    path = benchlog.write_log(tmp_path / "x.csv", df, {"condition": "x"}, exact=True)
    back = benchlog.read_log(path).df
    for c in df.columns:
        assert np.array_equal(back[c].to_numpy(float), df[c].to_numpy(float), equal_nan=True), c


@pytest.mark.parametrize("rate_hz", [12_000.0, 20_000.0, 1e6])
def test_a_fast_logs_clock_is_written_with_the_decimals_it_needs(tmp_path, rate_hz):
    """t_s at COLUMN_FORMATS' 4 decimals repeats itself above 10 kHz (hpddo twin --rate-hz 12000 and hpddo
    evaluate of a 20 kHz log ended in "t_s not increasing: 0.0001 after 0.0001"): it takes the decimals that
    keep it increasing; the other columns keep their formats."""
    import numpy as np
    import pandas as pd

    from hpddo.logs import benchlog

    n = 40
    df = pd.DataFrame({"t_s": np.arange(n) / rate_hz, "duty": np.full(n, 0.5), "v_V": np.full(n, 6.0),
                       "i_A": np.full(n, 0.2)})
    path = benchlog.write_log(tmp_path / "x.csv", df, {"condition": "x"})
    back = benchlog.read_log(path).df
    assert (np.diff(back["t_s"].to_numpy(float)) > 0).all()
    assert path.read_text().splitlines()[2].split(",")[2] == "6.000000"  # v_V as COLUMN_FORMATS writes it
