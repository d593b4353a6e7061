"""Bench log conformance (docs/bench-log.md): the corpus test/fixtures/logs through the
Python reader, the corpus and a differential fuzz through both readers.

The C++ reader is run through its printer `bench_log_check`, built by CMake in the
build folder: ./build (scripts/test.sh builds it before pytest), or the folder named by
the environment variable HPDDO_BUILD_DIR. A missing executable fails the test.
"""
import importlib.util
import math
import os
import pathlib
import random
import subprocess
import time

import numpy as np
import pytest

from hpddo.logs import benchlog
from hpddo.logs.benchlog import BenchLogError, read_log

ROOT = pathlib.Path(__file__).resolve().parents[2]
LOGS = ROOT / "test" / "fixtures" / "logs"
BUNDLED = sorted((ROOT / "data" / "default").glob("*.csv"))
BUNDLED = [p for p in BUNDLED if not p.name.endswith(".truth.csv")] + [ROOT / "test/fixtures/log_short.csv"]

FUZZ_LOGS = 2000
FUZZ_SEED = 20240909


def _expected():
    rows = (LOGS / "bad" / "EXPECTED.tsv").read_text(encoding="utf-8").splitlines()
    assert rows[0].split("\t") == ["file", "line", "fault", "what"]
    out = []
    for r in rows[1:]:
        name, line, fault, what = r.split("\t")
        out.append((name, int(line), fault, what))
    return out


EXPECTED = _expected()
GOOD = sorted((LOGS / "good").glob("*.csv"))


# ----------------------------------------------------------------------------- the corpus


def test_corpus_is_what_its_generator_writes():
    spec = importlib.util.spec_from_file_location("make_corpus", LOGS / "make_corpus.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    want = gen.build()
    have = {f"{p.parent.name}/{p.name}": p.read_bytes()
            for sub in ("good", "bad") for p in sorted((LOGS / sub).iterdir())}
    assert sorted(have) == sorted(want), "run test/fixtures/logs/make_corpus.py"
    for rel, data in want.items():
        assert have[rel] == data, f"{rel} differs from make_corpus.py's: run it"


def test_corpus_covers_every_fault():
    assert len(EXPECTED) >= 40
    assert {fault for _, _, fault, _ in EXPECTED} == set(benchlog.FAULTS)
    assert len(GOOD) >= 10
    assert sorted(p.name for p in (LOGS / "bad").glob("*.csv")) == sorted(e[0] for e in EXPECTED)


@pytest.mark.parametrize("path", GOOD + BUNDLED, ids=lambda p: p.name)
def test_good_log_is_accepted(path):
    log = read_log(path)
    assert len(log.df) == len(log.lines) >= 1
    assert (np.diff(log.lines) == 1).all()  # rows are consecutive lines


@pytest.mark.parametrize("name,line,fault,what", EXPECTED, ids=[e[0] for e in EXPECTED])
def test_bad_log_is_refused_with_line_and_fault(name, line, fault, what):
    path = LOGS / "bad" / name
    with pytest.raises(BenchLogError) as ei:
        read_log(path)
    err = ei.value
    assert (err.line, err.kind) == (line, fault), f"{what}: {err}"
    assert str(err).startswith(f"{path}:{line}: "), str(err)
    assert fault in str(err), str(err)  # the message says the keyword


# ----------------------------------------------------------------------------- the C++ reader


def check_exe() -> pathlib.Path:
    """The bench_log_check executable of the build folder; fails clearly when it is not built."""
    build = pathlib.Path(os.environ.get("HPDDO_BUILD_DIR", ROOT / "build"))
    exe = build / "test" / "host" / "bench_log_check"
    if not exe.is_file():
        pytest.fail(f"{exe} not found: build it first (cmake -S . -B {build} && cmake --build {build} "
                    f"--target bench_log_check; scripts/test.sh does), or set HPDDO_BUILD_DIR")
    return exe


def run_cpp(paths):
    """What the C++ reader reads from each path: ('FAULT', line, keyword) or ('OK', info)."""
    exe = check_exe()
    out = {}
    for k in range(0, len(paths), 500):  # keep the command line short
        chunk = [str(p) for p in paths[k:k + 500]]
        res = subprocess.run([str(exe), *chunk], capture_output=True, check=True)
        cur = None
        for ln in res.stdout.decode("utf-8").split("\n"):
            if ln.startswith("FILE "):
                cur = ln[5:]
            elif ln.startswith("FAULT "):
                _, line, kind = ln.split(" ", 2)
                out[cur] = ("FAULT", int(line), kind)
            elif ln.startswith("OK "):
                n, *flags = (int(v) for v in ln.split()[1:])
                out[cur] = ("OK", {"n": n, "flags": flags, "meta": {}, "rows": []})
            elif ln.startswith("M "):
                key, _, value = ln[2:].partition("=")
                out[cur][1]["meta"][key] = value
            elif ln.startswith("R "):
                out[cur][1]["rows"].append(ln.split()[1:])
        assert set(out) >= set(chunk), "bench_log_check printed no verdict for some files"
    return out


def run_py(path):
    """What the Python reader reads: ('FAULT', line, keyword) or ('OK', BenchLog)."""
    try:
        return ("OK", read_log(path))
    except BenchLogError as e:
        return ("FAULT", e.line, e.kind)


def _same_float(a: float, b: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b and math.copysign(1, a) == math.copysign(1, b)


def disagreement(py, cpp):
    """None when both readers read the same, else what differs."""
    if py[0] != cpp[0]:
        return f"python {py[0]} {py[1:] if py[0] == 'FAULT' else ''}, C++ {cpp[0]} {cpp[1:] if cpp[0] == 'FAULT' else ''}"
    if py[0] == "FAULT":
        return None if py == cpp else f"python {py[1:]}, C++ {cpp[1:]}"
    log, info = py[1], cpp[1]
    df = log.df
    if info["n"] != len(df):
        return f"rows: python {len(df)}, C++ {info['n']}"
    flags = [int(c in df.columns) for c in ("rpm_ref", "temp_C", "load", "seq")]
    if flags != info["flags"]:
        return f"columns present: python {flags}, C++ {info['flags']}"
    if info["meta"] != log.meta:
        return f"metadata: python {log.meta}, C++ {info['meta']}"
    names = ["t_s", "duty", "v_V", "i_A", "rpm_ref", "temp_C", "load", "seq"]
    for k, r in enumerate(info["rows"]):
        if int(r[0]) != int(log.lines[k]):
            return f"row {k}: line python {log.lines[k]}, C++ {r[0]}"
        for j, name in enumerate(names):
            if name not in df.columns:
                continue
            got = df[name].iloc[k]
            if name in ("load", "seq"):
                if int(r[j + 1]) != int(got):
                    return f"row {k} {name}: python {got}, C++ {r[j + 1]}"
            elif not _same_float(float(r[j + 1]), float(got)):
                return f"row {k} {name}: python {float(got)!r}, C++ {r[j + 1]}"
    return None


def test_cpp_reader_agrees_on_the_corpus():
    paths = GOOD + BUNDLED + [LOGS / "bad" / e[0] for e in EXPECTED]
    cpp = run_cpp(paths)
    for p in GOOD + BUNDLED:
        assert cpp[str(p)][0] == "OK", f"C++ refused {p}: {cpp[str(p)]}"
    for name, line, fault, what in EXPECTED:
        assert cpp[str(LOGS / "bad" / name)] == ("FAULT", line, fault), f"{name} ({what})"
    bad = {str(p): disagreement(run_py(p), cpp[str(p)]) for p in paths}
    assert not any(bad.values()), {p: d for p, d in bad.items() if d}


# ----------------------------------------------------------------------------- differential fuzz

ODD_CELLS = [
    "", " ", "\t", "1e-400", "1e400", "-1e400", "1e-310", "2.2250738585072014e-308", "+-1", "-+1", "1.0",
    "1e3", "9223372036854775807", "9223372036854775808", "9007199254740991", "9007199254740992",
    "18446744073709551616", "nan", "NaN", "-inf", "Infinity", "inf", "0x10", "1_0", "\u0661", "\u00a01",
    "1\u00a0", "\x0b1", "1\x0c", "-0", "+0", "0e999", ".5", "5.", ".", "-", "+", "e5", "1e", "1e+",
    "007", "256", "255", "-1", "+1", "0", "1", "2.5", " 3 ", "\t4\t", "#", "abc", "\x00", "1.7976931348623157e308",
    "1.7976931348623159e308", "4.9e-324", "0." + "0" * 320 + "1", "1" * 30, "1e-307",
]
ODD_BYTES = [b"\x00", b"\x0b", b"\x0c", b"\r", b"\n", b" ", b"\t", b",", b"#", b".", b"e", b"-", b"+", b"0",
             b"9", b"=", b"\x80", b"\xc0", b"\xc2", b"\xa0", b"\xe2", b"\xed", b"\xef", b"\xf4", b"\xff"]


def _number(rng: random.Random, lo: float, hi: float) -> str:
    x = rng.uniform(lo, hi)
    return rng.choice(["%.4f", "%.6f", "%g", "%.3e", "%.17g", "%.1f"]) % x


def _valid_log(rng: random.Random) -> bytes:
    """A random log the format accepts, in some of its many spellings."""
    cols = ["t_s", "duty", "v_V", "i_A"] + [c for c in ("rpm_ref", "temp_C", "load", "seq", "note", "x")
                                           if rng.random() < 0.6]
    rng.shuffle(cols)
    meta = []
    for k in range(rng.randrange(0, 4)):
        key = rng.choice(["condition", "sample_rate_hz", "motor", "note", "ra_ohm", "a.b-c_9"]) + str(k)
        pad = rng.choice(["", " ", "\t", "  "])
        meta.append(f"#{pad}{key}{pad}={pad}{rng.choice(['sweep', '2', '25GA371 1:4.4', '', 'a=b,c', '°C'])}")
    t = rng.uniform(-5, 5)
    rows = []
    for k in range(rng.randrange(1, 12)):
        t += rng.choice([0.5, 1e-3, 1.0, 7.25])
        cells = {"t_s": "%.6f" % t if rng.random() < 0.8 else repr(t), "duty": _number(rng, 0, 1),
                 "v_V": _number(rng, -1, 12), "i_A": _number(rng, -0.2, 2),
                 "rpm_ref": "" if rng.random() < 0.2 else _number(rng, 0, 300),
                 "temp_C": "" if rng.random() < 0.2 else _number(rng, -40, 120),
                 "load": str(rng.randrange(0, 256)), "seq": str(k + rng.choice([0, 0, 5, 65530])),
                 "note": rng.choice(["", "ok", "é", "a b", "#x"]), "x": _number(rng, -1e6, 1e6)}
        pad = rng.choice(["", "", " ", "\t"])
        rows.append(",".join(pad + cells[c] + pad for c in cols))
    eol = rng.choice(["\n", "\n", "\r\n"])
    text = eol.join(meta + [",".join(cols)] + rows) + (eol if rng.random() < 0.8 else "")
    data = text.encode("utf-8")
    return (b"\xef\xbb\xbf" + data) if rng.random() < 0.1 else data


def _mutate(rng: random.Random, data: bytes) -> bytes:
    """One random change of the kinds that broke the readers before docs/bench-log.md."""
    kind = rng.randrange(14)
    lines = data.split(b"\n")
    if kind == 0 and data:  # flip a byte to an odd one
        k = rng.randrange(len(data))
        return data[:k] + rng.choice(ODD_BYTES) + data[k + 1:]
    if kind == 1:  # insert an odd byte
        k = rng.randrange(len(data) + 1)
        return data[:k] + rng.choice(ODD_BYTES) + data[k:]
    if kind == 2 and data:  # delete a byte
        k = rng.randrange(len(data))
        return data[:k] + data[k + 1:]
    if kind == 3:  # a BOM, at the start or elsewhere
        k = 0 if rng.random() < 0.5 else rng.randrange(len(data) + 1)
        return data[:k] + b"\xef\xbb\xbf" + data[k:]
    if kind == 4:  # a blank line somewhere, trailing ones included
        k = rng.randrange(len(lines) + 1)
        return b"\n".join(lines[:k] + [rng.choice([b"", b" ", b"\r", b"\t "])] + lines[k:])
    if kind == 5:  # an odd cell
        k = rng.randrange(len(lines))
        cells = lines[k].split(b",")
        j = rng.randrange(len(cells))
        cells[j] = rng.choice(ODD_CELLS).encode("utf-8")
        lines[k] = b",".join(cells)
        return b"\n".join(lines)
    if kind == 6:  # duplicate a column in every line that has it
        j = rng.randrange(4)
        out = []
        for ln in lines:
            cells = ln.split(b",")
            if len(cells) > j:
                cells.insert(rng.randrange(len(cells) + 1), cells[j])
            out.append(b",".join(cells))
        return b"\n".join(out)
    if kind == 7:  # duplicate or drop a line
        k = rng.randrange(len(lines))
        return b"\n".join(lines[:k] + ([lines[k]] * 2 if rng.random() < 0.5 else []) + lines[k + 1:])
    if kind == 8 and len(lines) > 1:  # swap two lines
        a, b = rng.sample(range(len(lines)), 2)
        lines[a], lines[b] = lines[b], lines[a]
        return b"\n".join(lines)
    if kind == 9:  # a metadata or comment line anywhere
        k = rng.randrange(len(lines) + 1)
        line = rng.choice([b"# late=1", b"# just a comment", b"#=x", b"# condition=again", b"#k=v\r"])
        return b"\n".join(lines[:k] + [line] + lines[k:])
    if kind == 10:  # cut the file
        return data[:rng.randrange(len(data) + 1)]
    if kind == 11:  # a bare CR or a CR LF in place of a line end
        k = rng.randrange(len(data) + 1)
        return data[:k] + rng.choice([b"\r", b"\r\n", b"\r\r\n"]) + data[k:]
    if kind == 12:  # an invalid or exotic UTF-8 sequence
        k = rng.randrange(len(data) + 1)
        seq = rng.choice([b"\xc0\xaf", b"\xed\xa0\x80", b"\xf4\x90\x80\x80", b"\xe2\x82", b"\xc2\xa0",
                          b"\xe2\x80\xa8", b"\xf0\x9f\x99\x82", b"\xff", b"\x80"])
        return data[:k] + seq + data[k:]
    # kind 13: pad a cell with a no-break space, a vertical tab or a form feed
    k = rng.randrange(len(lines))
    cells = lines[k].split(b",")
    j = rng.randrange(len(cells))
    cells[j] = rng.choice([b"\xc2\xa0", b"\x0b", b"\x0c", b" ", b"\t"]) + cells[j]
    lines[k] = b",".join(cells)
    return b"\n".join(lines)


def fuzz_logs(n: int, seed: int):
    """n logs: random valid ones and corpus logs, each with 0 to 3 random mutations."""
    rng = random.Random(seed)
    seeds = [p.read_bytes() for p in GOOD] + [(LOGS / "bad" / e[0]).read_bytes() for e in EXPECTED]
    seeds += [b"".join(p.read_bytes().splitlines(keepends=True)[:12]) for p in BUNDLED]
    out = []
    for _ in range(n):
        data = _valid_log(rng) if rng.random() < 0.6 else rng.choice(seeds)
        for _ in range(rng.choice([0, 0, 1, 1, 2, 3])):
            data = _mutate(rng, data)
        out.append(data)
    return out


def test_differential_fuzz_both_readers_agree(tmp_path):
    start = time.perf_counter()
    paths = []
    for k, data in enumerate(fuzz_logs(FUZZ_LOGS, FUZZ_SEED)):
        p = tmp_path / f"fuzz{k:04d}.csv"
        p.write_bytes(data)
        paths.append(p)
    cpp = run_cpp(paths)
    results = {p: run_py(p) for p in paths}
    diffs = []
    for p in paths:
        d = disagreement(results[p], cpp[str(p)])
        if d:
            diffs.append(f"{p.name}: {d}\n    {p.read_bytes()[:300]!r}")
    accepted = sum(r[0] == "OK" for r in results.values())
    kinds = {r[2] for r in results.values() if r[0] == "FAULT"}
    elapsed = time.perf_counter() - start
    print(f"differential fuzz: {len(paths)} logs, {accepted} accepted, {len(kinds)} fault kinds, "
          f"{len(diffs)} disagreements, {elapsed:.1f} s")
    assert not diffs, f"{len(diffs)} disagreements of {len(paths)}:\n" + "\n".join(diffs[:20])
    # the fuzz reaches both sides of the format and most of its faults
    assert 0.15 * len(paths) < accepted < 0.85 * len(paths)
    assert len(kinds) >= 15, sorted(kinds)
