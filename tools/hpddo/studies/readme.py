"""README.md's tables of figures, generated from the committed JSON they come from,
between the markers of hpddo.regenerate's generated blocks:

    cd tools && ../.venv/bin/python -m hpddo.studies.readme --write      # or --check

(hpddo.regenerate writes what the declarations generate; these come from measurements, a
room above it.)

SOURCES names each committed JSON and the command that writes it; FIELDS maps each figure a
README table quotes to one value of one source (the declared mapping); BLOCKS declares each
generated table of README.md: its rows are text with {field} placeholders, no number typed
in. PROSE_TABLES declares the README's tables that quote no figure, by their header line,
with the only numbers they may hold (versions of the tools they name).
test/py/test_validation_figures.py holds README.md to this: each block is the rendering of
the committed JSON, each row's text holds no number outside a placeholder, and a table of
README.md that is neither a block nor a prose table fails.
"""
from __future__ import annotations

import hashlib
import json
import re
import sys

from .. import regenerate, resource_root
from . import validation

ROOT = resource_root()
COMMAND = "cd tools && ../.venv/bin/python -m hpddo.studies.readme --write"

#: name: (committed JSON, the command that writes it; None: the JSON's own "command")
SOURCES = {
    "validation": ("docs/figures/validation_table.json", "python -m hpddo.studies.validation --out DIR"),
    "compare": ("docs/figures/compare_table7.json", None),
    "bench": ("docs/figures/bench_observer.json", None),
    "model": ("models/default/metrics.json", "tools/gen_weights.py data/default/load.csv data/default/long.csv "
              "data/default/sweep.csv --name default --seed 1 --out models/default"),
}


def _pct(part: int, whole: int) -> float:
    return 100.0 * part / whole


def _thousand(v: float) -> float:
    return v / 1000.0


#: figure: (source, value of the source's JSON, format). One entry per figure quoted.
FIELDS = {
    "hidden": ("model", lambda j: "(" + ", ".join(map(str, j["identification"]["hidden"])) + ")", "{}"),
    "test_pct": ("compare", lambda j: 100.0 * (1.0 - j["settings"]["train_fraction"]), "{:.0f}"),
    "chrono_m1": ("validation", lambda j: j["plain_gate"]["chrono"]["M1"]["average"], "{:.1f}"),
    "chrono_m2": ("validation", lambda j: j["plain_gate"]["chrono"]["M2"]["average"], "{:.2f}"),
    "chrono_m3": ("validation", lambda j: j["plain_gate"]["chrono"]["M3"]["average"], "{:.2f}"),
    "chrono_lookup": ("validation", lambda j: j["plain_gate"]["chrono"]["lookup"]["average"], "{:.2f}"),
    "paper_m1": ("compare", lambda j: j["paper"]["M1"]["average"], "{:.1f}"),
    "paper_m2": ("compare", lambda j: j["paper"]["M2"]["average"], "{:.2f}"),
    "paper_m3": ("compare", lambda j: j["paper"]["M3"]["average"], "{:.2f}"),
    "unseen_m2_effects": ("validation", lambda j: j["effects_gate"]["validation"]["M2"]["unseen"], "{:.2f}"),
    "unseen_m3_nogate": ("validation", lambda j: j["effects_nogate"]["validation"]["M3"]["unseen"], "{:.2f}"),
    "unseen_m3_gate": ("validation", lambda j: j["effects_gate"]["validation"]["M3"]["unseen"], "{:.2f}"),
    "unseen_lookup": ("validation", lambda j: j["plain_gate"]["validation"]["lookup"]["unseen"], "{:.2f}"),
    "uno_flash_pct": ("bench", lambda j: _pct(j["uno_loop"]["flash_B"], j["uno_loop"]["flash_max_B"]), "{:.1f}"),
    "uno_flash_B": ("bench", lambda j: j["uno_loop"]["flash_B"], "{:,}"),
    "uno_flash_max_B": ("bench", lambda j: j["uno_loop"]["flash_max_B"], "{:,}"),
    "uno_ram_pct": ("bench", lambda j: _pct(j["uno_loop"]["ram_B"], j["uno_loop"]["ram_max_B"]), "{:.1f}"),
    "uno_ram_B": ("bench", lambda j: j["uno_loop"]["ram_B"], "{:,}"),
    "uno_ram_max_B": ("bench", lambda j: j["uno_loop"]["ram_max_B"], "{:,}"),
    "uno_rate_hz": ("bench", lambda j: j["uno_loop"]["rate_hz"], "{}"),
    "uno_windows": ("bench", lambda j: j["uno_loop"]["window"]["n"], "{}"),
    "uno_window_max_pct": ("bench", lambda j: _pct(j["uno_loop"]["window"]["max"], j["uno_loop"]["window_cycles"]),
                           "{:.1f}"),
    "avr_step_float_k": ("bench", lambda j: _thousand(j["avr"]["float"]["stages"]["step"]["median"]), "{:.1f}"),
    "avr_step_fixed_k": ("bench", lambda j: _thousand(j["avr"]["fixed"]["stages"]["step"]["median"]), "{:.1f}"),
    "avr_step_int8_k": ("bench", lambda j: _thousand(j["avr"]["int8"]["stages"]["step"]["median"]), "{:.1f}"),
    "avr_peer_k": ("bench", lambda j: _thousand(j["avr"]["peer"]["stages"]["peer_predict"]["median"]), "{:.1f}"),
    "avr_flash_float_B": ("bench", lambda j: j["avr"]["float"]["size"]["flash_B"], "{:,}"),
    "avr_flash_fixed_B": ("bench", lambda j: j["avr"]["fixed"]["size"]["flash_B"], "{:,}"),
    "avr_ram_float_B": ("bench", lambda j: j["avr"]["float"]["size"]["ram_B"], "{:,}"),
    "avr_ram_fixed_B": ("bench", lambda j: j["avr"]["fixed"]["size"]["ram_B"], "{:,}"),
    "avr_peer_flash_B": ("bench", lambda j: j["avr"]["peer"]["size"]["flash_B"], "{:,}"),
    "avr_peer_ram_B": ("bench", lambda j: j["avr"]["peer"]["size"]["ram_B"], "{:,}"),
    "avr_gate_float_k": ("bench", lambda j: _thousand(j["avr"]["float"]["stages"]["gate_hinted"]["median"]), "{:.1f}"),
    "avr_gate_fixed_k": ("bench", lambda j: _thousand(j["avr"]["fixed"]["stages"]["gate_hinted"]["median"]), "{:.1f}"),
    "avr_net_float_k": ("bench", lambda j: _thousand(j["avr"]["float"]["stages"]["residual"]["median"]), "{:.1f}"),
    "avr_net_fixed_k": ("bench", lambda j: _thousand(j["avr"]["fixed"]["stages"]["residual"]["median"]), "{:.1f}"),
    "lx_float_k": ("bench", lambda j: _thousand(j["lx106"]["float_16_8"]["step"]["median"]), "{:.1f}"),
    "lx_fixed_k": ("bench", lambda j: _thousand(j["lx106"]["fixed_16_8"]["step"]["median"]), "{:.1f}"),
    "lx_wide_float_k": ("bench", lambda j: _thousand(j["lx106"]["float_128_64"]["step"]["median"]), "{:.1f}"),
    "lx_wide_fixed_k": ("bench", lambda j: _thousand(j["lx106"]["fixed_128_64"]["step"]["median"]), "{:.1f}"),
    "lx_line": ("bench", lambda j: j["lx106"]["telemetry_line"]["line"]["median"], "{:,.0f}"),
    "host_float_M": ("bench", lambda j: j["host"]["float_16_8"] / 1e6, "{:.2f}"),
    "host_fixed_M": ("bench", lambda j: j["host"]["fixed_16_8"] / 1e6, "{:.2f}"),
    "host_sklearn_M": ("bench", lambda j: j["host"]["sklearn_16_8"] / 1e6, "{:.2f}"),
    "machine": ("bench", lambda j: j["machine"], "{}"),
    "upload_B": ("bench", lambda j: j["esp_upload"]["document_B"], "{:,}"),
    "upload_s": ("bench", lambda j: j["esp_upload"]["seconds"]["median"], "{:.2f}"),
    "upload_baud": ("bench", lambda j: j["esp_upload"]["baud"], "{}"),
}

#: README.md's "Measured figures": (figure, value, the document with the command), each
#: number a {field}.
MEASURED = (
    ("RMSE on the bundled recordings, held-out {test_pct} %, M1 / M2 / M3 {hidden} gated, average of sweep, "
     "load, long", "{chrono_m1} / {chrono_m2} / {chrono_m3} RPM (paper {paper_m1} / {paper_m2} / {paper_m3}); "
     "lookup baseline {chrono_lookup}", "`docs/pipeline.md`"),
    ("RMSE on never-seen operating points, M2 + named effects / M3 on top without / with the novelty gate",
     "{unseen_m2_effects} / {unseen_m3_nogate} / {unseen_m3_gate} RPM (lookup {unseen_lookup})",
     "`docs/validation.md`"),
    ("UNO sketch with the whole observer (fixed point)",
     "{uno_flash_pct} % of flash ({uno_flash_B} of {uno_flash_max_B} bytes), {uno_ram_pct} % of static RAM "
     "({uno_ram_B} of {uno_ram_max_B}); its {uno_rate_hz} Hz main loop uses at most {uno_window_max_pct} % of a "
     "window ({uno_windows} windows in simavr)", "`docs/firmware.md`, `docs/performance.md`"),
    ("observer step on the ATmega328P (simavr), {hidden}, float / fixed point / int8",
     "{avr_step_float_k} / {avr_step_fixed_k} / {avr_step_int8_k} thousand cycles median (emlearn's predict "
     "alone: {avr_peer_k} thousand)", "`docs/performance.md`"),
    ("observer step on the ESP8266's lx106 (QEMU, exact instruction counts), float / fixed point",
     "{hidden}: {lx_float_k} / {lx_fixed_k} thousand instructions median; the wide timing model: "
     "{lx_wide_float_k} / {lx_wide_fixed_k} thousand", "`docs/performance.md`"),
    ("one observer step and nothing else on the ATmega328P, default {hidden} model with its novelty gate, "
     "float / fixed point", "{avr_flash_float_B} / {avr_flash_fixed_B} B of flash, {avr_ram_float_B} / "
     "{avr_ram_fixed_B} B of static RAM (emlearn's predict alone: {avr_peer_flash_B} B flash, {avr_peer_ram_B} B "
     "RAM)", "`docs/performance.md`"),
    ("novelty gate per sample on the ATmega328P (simavr), float / fixed point",
     "{avr_gate_float_k} / {avr_gate_fixed_k} thousand cycles median (the {hidden} network: {avr_net_float_k} / "
     "{avr_net_fixed_k} thousand)", "`docs/performance.md`"),
    ("Observer::step on the host, one core, {hidden}, float / fixed point",
     "{host_float_M} / {host_fixed_M} million samples/s (scikit-learn's batched predict: {host_sklearn_M} "
     "million; {machine})", "`docs/performance.md`"),
    ("ESP8266 telemetry line with ArduinoJson on the lx106 (QEMU)", "{lx_line} instructions median",
     "`docs/firmware.md`"),
    ("`hpddo upload` of the default model", "{upload_B}-byte document, {upload_s} s median at an emulated "
     "{upload_baud} baud to the host-built board", "`docs/firmware.md`"),
)


def measured_table(fields: dict) -> str:
    rows = ["| figure | value | where |", "|---|---|---|"]
    rows += [f"| {label.format(**fields)} | {value.format(**fields)} | {where} |" for label, value, where in MEASURED]
    return "\n".join(rows) + "\n"


def rmse_table(fields: dict) -> str:
    return validation.rmse_table(load("validation"), load("model")["identification"]["hidden"])


#: name: (what, the sources, the row templates the test checks for typed-in numbers, the renderer)
BLOCKS = {
    "rmse": ("the RMSE table", ("validation", "model"), [label for label, _, _ in validation.RMSE_ROWS], rmse_table),
    "measured": ("the measured figures", ("validation", "compare", "bench", "model"),
                 [t for label, value, _ in MEASURED for t in (label, value)], measured_table),
}

#: README.md's tables that quote no figure: header line: the numbers they may hold (versions). None:
#: the README is the front door (the vendored libraries and what runs where are in docs/testing.md,
#: the repository's layout in docs/architecture.md).
PROSE_TABLES: dict = {}

#: A number in README text: not part of a name (ESP8266, C++11, lx106, CRC-16, v1).
NUMBER = re.compile(r"(?<![\w.+-])\d[\d,]*(?:\.\d+)*(?![\w])")


def load(name: str) -> dict:
    return json.loads((ROOT / SOURCES[name][0]).read_text())


def fields() -> dict:
    """{figure: its formatted value} of FIELDS, from the committed JSON."""
    data = {name: load(name) for name in SOURCES}
    return {k: fmt.format(get(data[src])) for k, (src, get, fmt) in FIELDS.items()}


def block(name: str, values: dict | None = None) -> str:
    """The text of a README.md block: whence (each source's checksum and command), then the table."""
    _, srcs, _, render = BLOCKS[name]
    whence = "; ".join(f"`{SOURCES[s][0]}` (sha256 {_sha(SOURCES[s][0])}, written by "
                       f"`{SOURCES[s][1] or load(s)['command']}`)" for s in srcs)
    return f"Generated from {whence}.\n\n{render(values if values is not None else fields())}"


def markers(name: str) -> tuple[str, str]:
    """A block's BEGIN and END lines (hpddo.regenerate's, with this command)."""
    what, srcs, _, _ = BLOCKS[name]
    return (regenerate.DOC_BEGIN.format(what=what, source=", ".join(SOURCES[s][0] for s in srcs), command=COMMAND),
            regenerate.DOC_END.format(what=what))


def marked(name: str, values: dict | None = None) -> str:
    """A block as README.md holds it, between its markers."""
    begin, end = markers(name)
    return f"{begin}\n{block(name, values)}{end}"


def generated(text: str) -> str:
    """README.md's text with each block as the committed JSON gives it; ValueError where a
    block's markers are missing."""
    values = fields()
    for name in BLOCKS:
        begin, end = markers(name)
        i, j = text.find(begin), text.find(end)
        if i < 0 or j < i:
            raise ValueError(f"README.md: the markers of {BLOCKS[name][0]} are missing")
        text = text[:i] + marked(name, values) + text[j + len(end):]
    return text


def _sha(path: str) -> str:
    return hashlib.sha256((ROOT / path).read_bytes()).hexdigest()[:16]


def tables(text: str) -> list[list[str]]:
    """The markdown tables of a text, each as its lines."""
    out, cur = [], None
    for line in text.splitlines():
        if line.startswith("|"):
            if cur is None:
                cur = []
                out.append(cur)
            cur.append(line)
        else:
            cur = None
    return out


def main(argv=None) -> int:
    from ..regenerate import write_or_check
    ap = write_or_check("python -m hpddo.studies.readme", __doc__, "README.md's blocks")
    args = ap.parse_args(argv)
    path = ROOT / "README.md"
    old = path.read_text(encoding="utf-8")
    new = generated(old)
    if new == old:
        print("README.md's tables of figures up to date")
    elif args.write:
        path.write_text(new, encoding="utf-8")
        print(f"wrote {', '.join(BLOCKS)} into {path}")
    else:
        print(f"README.md's tables of figures out of date (run: {COMMAND})", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
