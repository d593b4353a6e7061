"""The UNO's coast probes on the USB serial (uno_acq built with -DACQ_COAST=1, issue 33 item 7;
uno_acq/acq_coast.h): chunks of the ripple chunk's layout with their own sync byte (0x5C), the
current and the terminal voltage in turn, current first; `hpddo capture` writes them, through
logs/coast.py's writer, as the <condition>.coast.csv that `hpddo ripple --coast` reads, and the
estimator reads a probe's back-EMF from it. (The board's encoder and timing: the simavr tests
firmware.uno.sim_coast_*, test/firmware/check_uno_coast.py.)"""
import base64
import binascii
import pathlib
import re
import struct

import numpy as np
import pytest

from hpddo.cli import capture
from hpddo.logs import coast, ripple, ripple_link
from hpddo.ripple.coast import back_emf
from hpddo.ripple.options import CoastOptions
from hpddo.twin import params

ROOT = pathlib.Path(__file__).resolve().parents[2]


def chunk_bytes(seq, first, total, start_period, phase, codes, sync1=0x5C):
    """A chunk by the layout of uno_acq/acq_ripple.h, of the kind sync1."""
    n = len(codes)
    bits = sum(int(c) << (10 * k) for k, c in enumerate(codes))
    packed = bits.to_bytes((10 * n + 7) // 8, "little")
    body = struct.pack("<BIHHHHB", 13 + len(packed), seq, first, total, start_period, phase, n) + packed
    return bytes([0xA5, sync1]) + body + struct.pack("<H", binascii.crc_hqx(body, 0xFFFF))


def line(*args, **kw):
    return "~" + base64.b64encode(chunk_bytes(*args, **kw)).decode()


def header_constant(name):
    text = (ROOT / "uno_acq" / "acq_coast.h").read_text()
    return int(re.search(rf"static const uint32_t {name} = (\d+);", text).group(1))


def test_the_boards_probe_is_the_twins():
    """acq_coast.h's probe length and period are the twin's COAST_PROBE defaults (one concept, held equal)."""
    assert header_constant("kCoastProbeUs") == round(1e6 * params.COAST_PROBE["probe_s"].default)
    assert header_constant("kCoastPeriodMs") == round(1e3 * params.COAST_PROBE["period_s"].default)


def test_a_probe_chunk_is_told_from_a_burst_chunk():
    codes = list(range(40, 72))
    p = ripple_link.decode_line(line(9, 0, 40, 232, 641, codes))
    b = ripple_link.decode_line(line(9, 0, 768, 232, 641, codes, sync1=0x5B))
    assert p.coast and not b.coast and list(p.codes) == list(b.codes) == codes
    with pytest.raises(ripple_link.ChunkError, match="header"):
        ripple_link.decode_line(line(9, 0, 40, 232, 641, codes, sync1=0x5D))


def probe_codes(rng, e_V, i_A, n=40):
    """A probe's codes as the board takes them (current at even samples, voltage at odd ones): the
    current freewheels to zero within 0.6 ms, then the terminals show e_V falling 2 % in 4 ms."""
    a_code, v_code = 5 / 1024 / 0.5, 5 * 3 / 1024
    t = np.arange(n) / 10000
    i = np.clip(i_A * (1 - t / 0.0006), 0, None)
    v = np.where(t > 0.0006, e_V * (1 - 5 * t), 0.0)
    codes = np.where(np.arange(n) % 2 == 0, i / a_code, v / v_code) + rng.uniform(-0.5, 0.5, n)
    return np.clip(np.round(codes), 0, 1023).astype(int), (lambda ta: e_V * (1 - 5 * ta))


HEAD = ["! uno_acq 1 ready rate=2 pwm=10000", "# condition=warm", "# sample_rate_hz=2", "# pwm_hz=10000",
        "# divider_ratio=3", "# shunt_ohm=0.5", "# adc_ref_V=5", "# ripple_hz=10000", "# ripple_n=64",
        "# shunt_gain=1", "t_s,duty,v_V,i_A,rpm_ref,temp_C,load,seq"]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_capture_writes_the_probes_the_estimator_reads(tmp_path, seed):
    rng = np.random.default_rng(seed)
    stream, fed = list(HEAD), {}
    for k, s in enumerate(range(5, 11)):
        i_A = float(rng.uniform(0.3, 1.2))
        stream.append(f"{k * 0.5:.6f},0.8000,9.6,{i_A:.4f},150.0,,0,{s}")
        if s % 3 == 0:  # a probe in this window, in the burst's place
            codes, e = probe_codes(rng, float(rng.uniform(3, 11)), i_A)
            fed[s] = (codes, e, i_A)
            chunks = [line(s, 0, 40, 1032, 641, codes[:32].tolist()), line(s, 32, 40, 1032, 641, codes[32:].tolist())]
            if s == 9:
                chunks[1] = chunks[1][:30] + ("A" if chunks[1][30] != "A" else "B") + chunks[1][31:]  # damaged
            stream += chunks
        else:
            burst = rng.integers(0, 400, 64)
            stream += [line(s, f, 64, 1032, 641, burst[f:f + 32].tolist(), sync1=0x5B) for f in (0, 32)]
    stream.append("! end stopped overruns=0")
    out = tmp_path / "warm.csv"
    said = []
    capture.capture(FakePort(stream), out, "rec warm", progress=False, log=said.append)
    assert len(ripple.read(tmp_path / "warm.ripple.csv")) == 4  # the probes are not bursts
    p = coast.read(tmp_path / "warm.coast.csv")
    assert p.seq.tolist() == [6]  # seq 9's probe lost a chunk on the line: left out, counted
    assert any("coast probes" in s and "1 incomplete" in s for s in said)
    assert p.sample_hz == 10000 and p.a_per_code == pytest.approx(5 / 1024 / 0.5)
    assert p.v_per_code == pytest.approx(5 * 3 / 1024) and p.v_shift_V == 0
    codes, e, i_A = fed[6]
    assert p.i_codes[0].tolist() == codes[0::2].tolist() and p.v_codes[0].tolist() == codes[1::2].tolist()
    assert p.t_s[0] == pytest.approx(0.5 + (1032 * 1600 + 641) / 16e6)
    ti, ia = p.current(0)
    tv, vv = p.voltage(0)
    got, sd, t_a, why = back_emf(ti, ia, tv, vv, i_A, CoastOptions())
    assert why == "" and abs(got - e(t_a)) <= 3 * sd + 0.5 * p.v_per_code


def test_a_log_without_the_voltage_scale_is_refused_with_the_reason():
    with pytest.raises(ValueError, match="voltage channel's calibration"):
        ripple_link.coast_file("x.coast.csv", [], {"ripple_hz": "10000", "adc_ref_V": "5", "shunt_ohm": "0.5"}, {})


class FakePort:
    def __init__(self, lines):
        self.lines = [(l + "\n").encode() for l in lines]
        self.written = b""

    def write(self, b):
        self.written += b

    def readline(self):
        return self.lines.pop(0) if self.lines else b""
