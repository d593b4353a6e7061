"""The documentation site's pages (mkdocs.yml, docs/): the command reference is the parsers'
(hpddo.cli.reference), no user page is longer than a reader reads in one sitting, and no
user page carries change history (issue numbers, waves, "before this change"): git keeps the
history, the pages say what is. scripts/test.sh builds the site with mkdocs build --strict
(broken links, pages missing from the nav)."""
import re

import pytest

from conftest import ROOT

MAX_LINES = 400
HISTORY = re.compile(r"\b(issues? #?\d+|wave \d+|(before|after|since) this change|(before|after) (the|this) "
                     r"(fix|commit)|previously|no longer|as before|remeasured|first quoted|today's code|"
                     r"earlier main|on main)\b|\bbefore: |; now: |(?<![\w&])#\d+\b", re.IGNORECASE)


def user_pages():
    pages = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))
    return pages + ["README.md"]


def test_the_command_reference_is_the_parsers():
    from hpddo.cli import reference
    assert reference.stale(ROOT) == [], f"the command reference is out of date: {reference.COMMAND}"


def test_the_command_reference_names_every_option():
    from hpddo import cli
    from hpddo.cli import reference
    for name in cli.SUBCOMMANDS:
        page = (ROOT / reference.FOLDER / f"{name}.md").read_text(encoding="utf-8")
        assert page.startswith(f"# hpddo {name}\n")
        for action in cli.parser(name)._actions:
            for flag in action.option_strings:
                if flag not in ("-h", "--help"):
                    assert f"`{flag}`" in page, f"hpddo {name} {flag} missing from its page of {reference.FOLDER}/"


@pytest.mark.parametrize("page", user_pages())
def test_no_page_is_too_long(page):
    n = len((ROOT / page).read_text(encoding="utf-8").splitlines())
    assert n <= MAX_LINES, f"{page}: {n} lines (at most {MAX_LINES}: split it by what the reader needs)"


@pytest.mark.parametrize("page", user_pages())
def test_no_page_carries_change_history(page):
    bad = [f"{page}:{k}: {m.group(0)!r}" for k, line in enumerate((ROOT / page).read_text(encoding="utf-8").splitlines(), 1)
           for m in HISTORY.finditer(line)]
    assert not bad, "change history in a user page (git keeps it):\n" + "\n".join(bad)


def test_the_history_rule_sees_history_and_not_physics():
    assert HISTORY.search("the brush drop (issue 21, item 7)") and HISTORY.search("since wave 3")
    assert HISTORY.search("RMSE before this change") and HISTORY.search("see #34")
    assert HISTORY.search("before: 1.35 ohm; now: 5.29 ohm") and HISTORY.search("named as before")
    assert not HISTORY.search("the error before and after adding the effect; 0.5 V at 20 % duty")


def _log_keys_read_by_the_tools() -> dict:
    """{key: where} of every metadata key a module of hpddo reads by name: `meta["k"]`,
    `meta.get("k")` on a name or attribute that holds "meta" (the readers' metadata dicts)."""
    import ast
    out = {}
    for path in sorted((ROOT / "tools" / "hpddo").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            target, key = None, None
            if isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant):
                target, key = node.value, node.slice.value
            elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get"
                  and node.args and isinstance(node.args[0], ast.Constant)):
                target, key = node.func.value, node.args[0].value
            name = target.id if isinstance(target, ast.Name) else target.attr if isinstance(target, ast.Attribute) else ""
            if isinstance(key, str) and "meta" in name.lower():
                out.setdefault(key, f"{path.relative_to(ROOT)}:{node.lineno}")
    return out


def test_every_log_key_is_documented():
    """Every column and metadata key a bench log carries, as the code declares, reads or (the
    UNO firmware) writes it, is named in docs/bench-log.md: a new key without its line there
    fails here."""
    from hpddo.logs import benchlog, dataset
    doc = (ROOT / "docs" / "bench-log.md").read_text(encoding="utf-8")
    keys = {k: "benchlog.KNOWN_COLUMNS" for k in benchlog.KNOWN_COLUMNS}
    keys.update({k: "dataset.SENSOR_KEYS" for k in dataset.SENSOR_KEYS})
    keys.update({k: "dataset.SENSOR_COLUMNS" for k in dataset.SENSOR_COLUMNS})
    keys["kind"] = "dataset.KINDS"
    keys.update({k: f"kind {k}" for k in dataset.KINDS})
    keys.update(_log_keys_read_by_the_tools())
    fw = (ROOT / "uno_acq" / "uno_acq.cpp").read_text(encoding="utf-8")
    keys.update({k: "uno_acq.cpp, begin_recording" for k in re.findall(r'meta(?:_compact|_u32)?\(F\("(\w+)"\)', fw)})
    for header in ("acq_format.h", "acq_ripple_board.h"):
        text = (ROOT / "uno_acq" / header).read_text(encoding="utf-8")
        for cols in re.findall(r'kLogHeader\w*\[\] = "([^"]*)"', text):
            keys.update({c: f"uno_acq/{header}" for c in cols.split(",") if c})
    assert len(keys) > 30
    missing = sorted(f"{k} ({where})" for k, where in keys.items() if f"`{k}`" not in doc)
    assert not missing, "keys of the bench log not in docs/bench-log.md:\n" + "\n".join(missing)


def test_the_pictures_are_what_their_code_draws():
    """docs/figures/dataflow.svg and diagnosis_before_after.svg are what hpddo.studies.figures
    writes now (the before/after from the committed validation table), byte for byte."""
    from hpddo.studies import figures
    for rel, text in figures.generated().items():
        assert (ROOT / rel).read_text(encoding="utf-8") == text, f"{rel} is out of date: {figures.COMMAND}"


def test_every_step_of_the_dataflow_names_a_module_that_exists():
    from hpddo.studies import figures
    for step, (*_, module) in figures.STEPS.items():
        assert (ROOT / module).exists(), f"{figures.DATAFLOW}: {step} names {module}, which does not exist"
    for a, b, _ in figures.FLOWS:
        assert a in figures.STEPS and b in figures.STEPS


def _fenced(page: str, lang: str) -> list:
    """The text of each ```lang block of a page."""
    return re.findall(rf"^```{lang}\n(.*?)^```$", page, re.S | re.M)


@pytest.mark.slow
def test_the_dyno_table_page_shows_what_its_command_prints(tmp_path):
    """docs/diagnose-table.md: its table is a valid bench log, and `hpddo diagnose` on it prints
    the lines the page quotes, in order, as the page types the command."""
    import shlex
    import subprocess
    import sys
    page = (ROOT / "docs" / "diagnose-table.md").read_text(encoding="utf-8")
    (table,), (command,), (printed,) = _fenced(page, "csv"), _fenced(page, "sh"), _fenced(page, "text")
    (tmp_path / "dyno30.csv").write_text(table, encoding="utf-8")
    argv = shlex.split(command.strip())
    assert argv[:2] == ["hpddo", "diagnose"]
    run = subprocess.run([sys.executable, "-m", "hpddo", *argv[1:]], cwd=tmp_path, capture_output=True, text=True,
                         env={**__import__("os").environ, "PYTHONPATH": str(ROOT / "tools")}, timeout=600)
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines()[:len(printed.splitlines())] == printed.splitlines()
    assert (tmp_path / "dyno-diagnosis" / "diagnosis.json").exists()


def test_the_board_commands_and_telemetry_fields_are_documented():
    """Every command the two sketches accept and every field of the ESP8266's telemetry line, as
    the firmware's sources spell them, is in its reference page: a new command or field without
    its line there fails here."""
    esp_doc = (ROOT / "docs" / "esp8266.md").read_text(encoding="utf-8")
    app = (ROOT / "esp_infer" / "infer_app.h").read_text(encoding="utf-8")
    commands = re.findall(r'strcmp\(cmd, "(\w+)"\) == 0', app)
    assert len(commands) >= 7
    assert not [c for c in commands if f'`{{"cmd":"{c}"' not in esp_doc], "ESP8266 command missing from docs/esp8266.md"
    line = (ROOT / "esp_infer" / "infer_line.h").read_text(encoding="utf-8")
    fields = re.findall(r'doc\["(\w+)"\]', line[line.index("class LineWriter"):])
    assert len(fields) >= 12
    assert not [f for f in fields if f"| `{f}` |" not in esp_doc], "telemetry field missing from docs/esp8266.md"
    uno_doc = (ROOT / "docs" / "firmware.md").read_text(encoding="utf-8")
    words = sorted(set(re.findall(r'word_eq\(s, e, "(\w+)"\)', (ROOT / "uno_acq" / "acq_command.h").read_text())))
    assert len(words) >= 10
    section = uno_doc[uno_doc.index("## Serial commands of the UNO"):]
    section = section[:section.index("\n## ", 1)]
    assert not [w for w in words if f"`{w}" not in section and f", `{w} " not in section], \
        "UNO command missing from docs/firmware.md, Serial commands of the UNO"


# `docs/NAME.md, "Section"`, `docs/NAME.md "Section"` or `docs/NAME.md ("Section")` in a comment, docstring or
# help string; the quote may begin on the next comment line and run over a line break
DOC_CITATION = re.compile(r'docs/([\w/-]+\.md),?[ \t]*(?:\n[ \t]*(?://+|#+)?[ \t]*)?\(?\\?"(\w[^"\\]{0,150})\\?"')
CITING_FOLDERS = ("tools", "lib", "host", "uno_acq", "esp_infer", "test", "scripts")
CITING_SUFFIXES = (".py", ".h", ".cpp", ".ino", ".sh")


def _doc_citations() -> list:
    """(where, page, section) of every section of a docs page cited by name in the source tree."""
    out = []
    for folder in CITING_FOLDERS:
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix not in CITING_SUFFIXES or not path.is_file() or path.name == "test_docs.py":
                continue  # this file's citations are the pattern's own examples
            text = path.read_text(encoding="utf-8", errors="replace")
            for m in DOC_CITATION.finditer(text):
                section = " ".join(re.sub(r"\n\s*(?://+|#+|\*)?", " ", m.group(2)).split())
                where = f"{path.relative_to(ROOT)}:{text.count(chr(10), 0, m.start()) + 1}"
                out.append((where, m.group(1), section))
    return out


def _headings(page: str) -> list:
    text = re.sub(r"^```.*?^```", "", page, flags=re.S | re.M)
    return [" ".join(h.split()).lower() for h in re.findall(r"^#+\s+(.*)$", text, re.M)]


def test_the_citation_pattern_reads_every_form():
    found = lambda s: [(m.group(1), m.group(2)) for m in DOC_CITATION.finditer(s)]  # noqa: E731
    assert found('(docs/ripple.md, "Which line is the ripple")') == [("ripple.md", "Which line is the ripple")]
    assert found('docs/ripple-accuracy.md "Stall": the') == [("ripple-accuracy.md", "Stall")]
    assert found('docs/bench-log.md ("Ripple bursts") gives') == [("bench-log.md", "Ripple bursts")]
    assert found('in acq_ripple.h; docs/ripple-board.md,\n// "The UNO\'s ripple mode".')[0][1] == "The UNO's ripple mode"
    assert found('(docs/ripple.md)") and "next string"') == []


def test_every_cited_section_of_a_page_exists():
    """Every `docs/NAME.md, "Section"` a comment, docstring or help string of the source tree cites
    names a heading of that page (one that starts with the quoted words): a page split or a section
    renamed without its citations fails here."""
    cites = _doc_citations()
    assert len(cites) > 20, cites
    bad = []
    for where, name, section in cites:
        page = ROOT / "docs" / name
        if not page.is_file():
            bad.append(f"{where}: docs/{name} does not exist")
        elif not any(h.startswith(section.lower()) for h in _headings(page.read_text(encoding="utf-8"))):
            bad.append(f"{where}: docs/{name} has no heading \"{section}\"")
    assert not bad, "citations of a docs section that is not there:\n" + "\n".join(bad)


def test_the_pages_quote_the_uno_loop_as_measured():
    """The UNO's 100 Hz main loop, with and without the ripple counter, is quoted by docs/firmware.md,
    performance-cycles.md and ripple-board-count.md as the committed run of `hpddo bench --observer
    --write-docs` measured it (docs/figures/bench_observer.json, the table of docs/performance.md):
    a run that moves the figures fails here until the prose follows it."""
    import json
    fig = json.loads((ROOT / "docs" / "figures" / "bench_observer.json").read_text(encoding="utf-8"))
    loop, rip = fig["uno_loop"], fig["uno_ripple_loop"]
    quoted = {
        "firmware.md": [(loop, "window", "max"), (loop, "observer", "max"), (rip, "window", "max")],
        "performance-cycles.md": [(r, part, stat) for r, part in ((loop, "window"), (loop, "observer"), (rip, "window"),
                                                                   (rip, "ripple")) for stat in ("median", "max")],
        "ripple-board-count.md": [(rip, part, stat) for part in ("window", "observer", "ripple")
                                  for stat in ("median", "max")],
    }
    bad = []
    for name, figures in quoted.items():
        text = " ".join((ROOT / "docs" / name).read_text(encoding="utf-8").split())
        for r, part, stat in figures:
            n, what = r[part][stat], f"docs/{name}: the {'counting build' if r is rip else 'loop'}'s {part} {stat}"
            cycles = f"{n:,}".replace(",", " ")
            if cycles not in text:
                bad.append(f"{what}, {cycles} cycles")
            pct = f"{100.0 * n / r['window_cycles']:.1f} %"
            if (part, stat) == ("window", "max") and pct not in text:
                bad.append(f"{what}, {pct} of the window")
    assert not bad, "not as docs/figures/bench_observer.json measured:\n" + "\n".join(bad)
