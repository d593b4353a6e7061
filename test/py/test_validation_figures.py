"""The figures in README.md and docs/validation.md are the measured ones: they match the
committed JSON they come from (docs/figures/validation_table.json, written by python -m
hpddo.studies.validation, whose gated plain-physics chronological figures are those of the
regenerated models/default; docs/figures/bench_observer.json, written by hpddo bench
--observer --write-docs; docs/figures/compare_table7.json). Every table of README.md is either
generated from them (hpddo.studies.readme, its declared mapping) or declared to quote no figure."""
import json
import os
import shutil
import subprocess

import pytest

from conftest import ROOT

from hpddo.studies import readme, validation

TABLE = json.loads((ROOT / "docs" / "figures" / "validation_table.json").read_text())


def test_docs_table_is_the_committed_measurement():
    assert validation.table(TABLE) in (ROOT / "docs" / "validation.md").read_text()


def test_committed_measurement_agrees_with_the_committed_default_model():
    metrics = json.loads((ROOT / "models" / "default" / "metrics.json").read_text())
    assert TABLE["plain_gate"]["chrono"] == metrics["rmse_rpm"]


@pytest.mark.parametrize("variant,part,model,cond", [
    ("effects_gate", "validation", "M3", "unseen"), ("effects_nogate", "validation", "M3", "unseen"),
    ("effects_gate", "validation", "M2", "unseen"), ("plain_gate", "validation", "lookup", "unseen"),
    ("effects_gate", "chrono", "M3", "average"), ("effects_nogate", "chrono", "M3", "average")])
def test_readme_quotes_the_measurement(variant, part, model, cond):
    assert f"{TABLE[variant][part][model][cond]:.2f}" in (ROOT / "README.md").read_text()


def test_the_gate_meets_the_goals_on_the_bundled_recordings():
    """With the gate, M3 on never-seen recordings within 5 % of its physics or better;
    the chronological gain kept within 10 % of the ungated one."""
    for phys in ("plain", "effects"):
        g, ng = TABLE[f"{phys}_gate"], TABLE[f"{phys}_nogate"]
        for c in ("hot", "unseen"):
            assert g["validation"]["M3"][c] <= 1.05 * g["validation"]["M2"][c], (phys, c)
        gain_g = g["chrono"]["M2"]["average"] - g["chrono"]["M3"]["average"]
        gain_ng = ng["chrono"]["M2"]["average"] - ng["chrono"]["M3"]["average"]
        assert gain_g >= 0.9 * gain_ng, phys


README = (ROOT / "README.md").read_text()


def test_readme_blocks_are_generated_from_the_committed_json():
    """python -m hpddo.studies.readme --write writes them; a figure typed in, or a JSON changed
    without the README, fails here."""
    for name in readme.BLOCKS:
        assert readme.marked(name) in README, f"README.md's {readme.BLOCKS[name][0]}: run {readme.COMMAND}"
    assert readme.generated(README) == README


def test_every_readme_table_is_generated_or_quotes_no_figure():
    """A table of README.md outside the generated blocks must be declared in
    readme.PROSE_TABLES, and hold no number but the versions declared there: a new table of
    hand-typed figures fails."""
    blocks = [readme.marked(name) for name in readme.BLOCKS]
    found = set()
    for table in readme.tables(README):
        text = "\n".join(table) + "\n"
        if any(text in b for b in blocks):
            continue
        assert table[0] in readme.PROSE_TABLES, f"README.md table not generated nor declared: {table[0]}"
        found.add(table[0])
        numbers = set(readme.NUMBER.findall(text))
        assert numbers <= set(readme.PROSE_TABLES[table[0]]), (table[0], numbers - set(readme.PROSE_TABLES[table[0]]))
    assert found == set(readme.PROSE_TABLES), "a declared prose table is gone from README.md: drop its declaration"


def test_readme_tables_type_no_number_outside_the_mapping():
    """The rows of a generated table carry no number of their own: each is a {field} of
    readme.FIELDS, from one of the block's declared sources."""
    import string
    for name, (_, sources, templates, _) in readme.BLOCKS.items():
        for t in templates:
            parts = list(string.Formatter().parse(t))
            literal = "".join(lit for lit, _, _, _ in parts)
            assert not readme.NUMBER.findall(literal), (name, t)
            for _, field, _, _ in parts:
                if field is not None and name != "rmse":
                    assert readme.FIELDS[field][0] in sources, (name, field)


def test_the_number_rule_sees_a_typed_figure_and_not_a_name():
    assert readme.NUMBER.findall("71.1 % of flash, 5,532 B, 0.06 us") == ["71.1", "5,532", "0.06"]
    assert readme.NUMBER.findall("ESP8266, C++11, lx106, CRC-16, ATmega328P, v2") == []


def test_firmware_doc_quotes_the_committed_uno_sizes():
    """docs/firmware.md's UNO flash and RAM rows are the committed bench run's (hpddo bench
    --observer --write-docs, docs/figures/bench_observer.json's uno_loop)."""
    u = readme.load("bench")["uno_loop"]
    doc = (ROOT / "docs" / "firmware.md").read_text()
    sp = lambda n: f"{n:,}".replace(",", " ")
    assert (f"| UNO flash, with the observer (fixed point, the default) | {sp(u['flash_B'])} of {sp(u['flash_max_B'])} "
            f"bytes ({100 * u['flash_B'] / u['flash_max_B']:.1f} %") in doc
    assert (f"| UNO RAM (static), with the observer | {u['ram_B']} of {u['ram_max_B']} bytes "
            f"({100 * u['ram_B'] / u['ram_max_B']:.1f} %)") in doc


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("avr-g++") is None, reason="avr-g++ not installed (scripts/bootstrap.sh --tests)")
def test_committed_uno_sizes_are_the_builds(tmp_path):
    """uno_acq as built now (test/firmware/build_uno.sh, as hpddo bench --observer builds it)
    has the flash and RAM the committed JSON records: a firmware change without the bench
    rerun fails here, before README.md quotes a stale size."""
    subprocess.run(["bash", str(ROOT / "test" / "firmware" / "build_uno.sh"), str(ROOT), str(tmp_path / "uno")],
                   check=True, capture_output=True, env={k: v for k, v in os.environ.items() if k != "ACQ_DEFINES"})
    flash, flash_max, ram, ram_max = map(int, (tmp_path / "uno" / "uno_acq.size").read_text().split())
    u = readme.load("bench")["uno_loop"]
    assert (flash, flash_max, ram, ram_max) == (u["flash_B"], u["flash_max_B"], u["ram_B"], u["ram_max_B"]), \
        f"rerun hpddo bench --observer --write-docs, then {readme.COMMAND}"
