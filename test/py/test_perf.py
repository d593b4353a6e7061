"""The committed benchmark figures (docs/figures/bench_observer.json) and the table in
docs/performance.md are one measurement: the table is perf.table() of the figures. And
the measurement itself was sound: no step off its golden row on the AVR."""
import json

from conftest import ROOT
from hpddo import perf


def test_committed_table_is_the_table_of_the_committed_figures():
    fig = json.loads(perf.FIGURES.read_text())
    doc = perf.DOC.read_text()
    block = doc[doc.index(perf.BEGIN):doc.index(perf.END)]
    assert perf.table(fig) in block
    assert f"`{perf.COMMAND}`" in block


def test_committed_measurement_had_no_golden_miss_and_a_peer():
    fig = json.loads(perf.FIGURES.read_text())
    assert fig["avr"]["float"]["golden_misses"] == 0
    assert fig["avr"]["fixed"]["golden_misses"] == 0
    assert fig["avr"]["peer"]["status"] == "run"
    steps = fig["avr"]["fixed"]["stages"]["step"]
    assert steps["n"] >= 70 and steps["median"] <= steps["max"]
