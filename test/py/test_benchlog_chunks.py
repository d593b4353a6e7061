"""The bench log reader reads a file a chunk at a time (benchlog.CHUNK_BYTES, cut at line ends):
the same result, or the same fault on the same line, whatever the chunk size, on the
conformance corpus and on the differential fuzz logs; a fault early in a large file is
refused having parsed only its first chunk."""
import io
import pathlib
import random

import numpy as np
import pandas as pd
import pytest

from hpddo.logs import benchlog
from test_conformance import FUZZ_SEED, _mutate, _valid_log

CORPUS = sorted((pathlib.Path(__file__).resolve().parents[1] / "fixtures" / "logs").glob("*/*.csv"))
SIZES = (1, 3, 40, 256)


def _outcome(raw: bytes, size: int):
    try:
        meta, df, lines = benchlog._parse_stream(benchlog._blocks(io.BytesIO(raw), size))
    except benchlog._Fault as f:
        return ("fault", f.line, f.kind, f.message)
    return ("ok", meta, df, lines.tolist())


def _same(a, b) -> bool:
    if a[0] != b[0] or a[0] == "fault":
        return a == b
    if a[1] != b[1] or a[3] != b[3] or list(a[2].columns) != list(b[2].columns):
        return False
    try:
        pd.testing.assert_frame_equal(a[2], b[2])
    except AssertionError:
        return False
    return True


def _samples():
    rng = random.Random(FUZZ_SEED + 1)
    out = [p.read_bytes() for p in CORPUS]
    for _ in range(200):
        data = _valid_log(rng)
        out.append(data if rng.random() < 0.3 else _mutate(rng, data))
    return out


def test_the_corpus_is_there():
    assert len(CORPUS) > 100


@pytest.mark.parametrize("size", SIZES)
def test_every_chunk_size_reads_the_same(size):
    for raw in _samples():
        whole = _outcome(raw, 1 << 30)
        assert _same(_outcome(raw, size), whole), (raw[:300], whole[:4] if whole[0] == "fault" else "ok")


def test_t_s_not_increasing_across_a_chunk_boundary_names_both_values():
    raw = b"t_s,duty,v_V,i_A\n0.5,0.1,1,0.1\n1.0,0.1,1,0.1\n1.0,0.1,1,0.1\n"
    assert _outcome(raw, 16)[:3] == ("fault", 4, "t_s not increasing")
    assert "1.0 after 1.0" in _outcome(raw, 16)[3]


def test_an_early_fault_in_a_large_file_is_refused_from_its_first_chunk(tmp_path, monkeypatch):
    """Line 7207 of a file of 400 000 rows: the rows parsed are the first chunk's, not the file's
    (the rest is only decoded, as the format checks the encoding over the whole file first)."""
    from hpddo.studies.large_log import write_synthetic
    path = write_synthetic(tmp_path / "big.csv", rows=400_000, fault_line=7207)
    parsed = []
    real = benchlog._parse_rows
    monkeypatch.setattr(benchlog, "_parse_rows", lambda columns, data, *a: (parsed.append(len(data)),
                                                                          real(columns, data, *a))[1])
    with pytest.raises(benchlog.BenchLogError) as ei:
        benchlog.read_log(path)
    assert ei.value.line == 7207 and ei.value.kind == "non-numeric", str(ei.value)
    assert f"{path}:7207: non-numeric value 'abc' in column v_V" in str(ei.value)
    assert len(parsed) == 1 and parsed[0] < 400_000 / 3, parsed  # one chunk of rows parsed, the first
    log_rows = benchlog.read_log(write_synthetic(tmp_path / "good.csv", rows=400_000))
    assert len(log_rows.df) == 400_000 and np.all(np.diff(log_rows.df["t_s"].to_numpy()) > 0)


def test_write_log_checks_each_chunk_and_across_the_cut(tmp_path, monkeypatch):
    """write_log formats and reads back a chunk at a time: two t_s equal once written, inside a
    chunk or across a cut, are refused with the file line, and nothing is written (t_s held to 4 decimals here:
    write_log itself takes the decimals a strictly increasing t_s needs, benchlog._time_format)."""
    monkeypatch.setattr(benchlog, "WRITE_CHUNK_ROWS", 7)
    monkeypatch.setattr(benchlog, "_time_format", lambda t: "%.4f")
    for row in (20, 21):  # chunks of rows 14..20 and 21..27: inside one, and the first of the next
        t = np.arange(30) * 0.5
        t[row] = t[row - 1] + 1e-5
        df = pd.DataFrame({"t_s": t, "duty": 0.5, "v_V": 6.0, "i_A": 0.3})
        with pytest.raises(ValueError, match=rf"line {row + 3}: t_s not increasing"):
            benchlog.write_log(tmp_path / "x.csv", df, {"a": "1"})
        assert list(tmp_path.iterdir()) == []
    df = pd.DataFrame({"t_s": np.arange(30) * 0.5, "duty": 0.5, "v_V": 6.0, "i_A": 0.3, "note": "ok"})
    benchlog.write_log(tmp_path / "x.csv", df, {"a": "1"})
    back = benchlog.read_log(tmp_path / "x.csv")
    assert back.df["t_s"].tolist() == df["t_s"].tolist() and back.lines.tolist() == list(range(3, 33))


def test_the_replays_estimates_read_in_chunks_are_the_file_with_its_words_as_categories(tmp_path, monkeypatch):
    """metrics.read_estimates reads ESTIMATES_CHUNK_ROWS rows at a time: the same values as the
    whole file read at once, status and part as categories (one copy of each word: 2 000 000 rows
    of them as text took 240 MB in hpddo evaluate)."""
    from hpddo.evaluation import metrics
    n = 1000
    rng = np.random.default_rng(1)
    whole = pd.DataFrame({"t_s": np.arange(n) * 0.5, "rpm_ref": rng.normal(100, 5, n), "rpm_m3": rng.normal(100, 5, n),
                          "status": rng.choice(["ok", "gated", "fallback"], n),
                          "part": np.where(np.arange(n) < 800, "train", "test")})
    whole.loc[990:, "status"] = "clamped"  # a word only the last chunk has
    whole.to_csv(tmp_path / "e.estimates.csv", index=False)
    monkeypatch.setattr(metrics, "ESTIMATES_CHUNK_ROWS", 300)
    got = metrics.read_estimates(tmp_path / "e.estimates.csv")
    assert list(got.columns) == list(whole.columns) and len(got) == n
    assert isinstance(got["status"].dtype, pd.CategoricalDtype) and isinstance(got["part"].dtype, pd.CategoricalDtype)
    pd.testing.assert_frame_equal(got.astype({"status": str, "part": str}), whole.astype({"status": str, "part": str}),
                                  check_exact=False, rtol=1e-15)
    assert (got["status"] == "clamped").sum() == 10 and got.index[got["part"] == "test"][0] == 800
