"""The HTML reports from one template module (hpddo.reports): the training report
(hpddo.reports.training) and the diagnosis report (hpddo.reports.diagnosis) render from the
templates with every text escaped, show the same tables and sentences as the f-string
pages they replace (the expected values below are what those pages showed for the same
input), share one stylesheet and one figure helper, and open in headless Chromium
without console errors. diagnosis.json is json.dumps(res, indent=1) as before."""
import json
import pathlib
import re
import tomllib
from html.parser import HTMLParser

import matplotlib
import numpy as np
import pandas as pd
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from conftest import ROOT  # noqa: E402

from hpddo.reports import browser
from hpddo import reports  # noqa: E402
from hpddo.reports import training as report  # noqa: E402
from hpddo.reports import diagnosis as diagnosis_report  # noqa: E402

EVIL = "<script>alert('x')</script>"
RAW_EVIL = re.compile(r"<script\b", re.I)


# ---------------------------------------------------------------- fixed inputs


def training_metrics():
    return {
        "rmse_rpm": {
            "M1": {"sweep": 85.4215, "load": 362.419, EVIL: 12.0, "average": 153.28},
            "M2": {"sweep": 4.1349, "load": 13.921, EVIL: 12.0, "average": 10.02},
            "M3": {"sweep": 2.5061, "load": 13.99, EVIL: 3.004, "average": 6.5},
        },
        "clamped_share": {"sweep": 0.0, "load": 0.0123, EVIL: 0.5},
        "fallback_share": {"sweep": 0.001, "load": 0.0, EVIL: 0.25},
        "glitches_removed": {"sweep": {"removed": [4, 9, 17], "rows_in_file": 660},
                             EVIL: {"removed": [], "rows_in_file": 12}},
        "warnings": ["Ra & Ke <fitted> at the bound"],
    }


def estimates(n=40):
    t = np.arange(n) * 0.5
    ref = 100 + 10 * np.sin(t)
    return pd.DataFrame({"t_s": t, "rpm_ref": ref, "rpm_m1": 3 * ref, "rpm_m2": ref + 2, "rpm_m3": ref + 0.5,
                         "part": ["train"] * (n - n // 5) + ["test"] * (n // 5)})


def diagnosis_result():
    def analysis(mse, white, sig):
        return {"mse": mse, "noise_var": 5.85,
                "whiteness": {"q": 2353.21 if not white else 20.01, "p": 0.0 if not white else 0.45961,
                              "outside": 1.0 if not white else None, "white": white, "band": 0.05,
                              "acf": [1.0, 0.6, 0.3, 0.1]},
                "correlates": [{"input": "speed", "peak": 0.6812, "significant": sig, "band": 0.1,
                                "ccf": [0.1, 0.6812, 0.2]},
                               {"input": "I <A>", "peak": -0.5301, "significant": sig, "band": 0.1,
                                "ccf": [0.0, -0.5301, 0.1]}]}

    return {
        "recordings": [{"name": "load", "rows": 597}, {"name": EVIL, "rows": 12}],
        "warnings": [], "ra_ohm": 4.5, "ra_source": "log metadata ra_ohm", "model_effects": [],
        "missing_effects": ["thermal_ra", "current_offset"],
        "confounded": [["current_offset", "brush_drop"]],
        "separating_recordings": [{"effects": ["current_offset", "brush_drop"], "corr": -0.99918,
                                   "recording": "rows at zero current <coasting>"}],
        "not_identifiable": [{"effect": "inductance", "needs": "a recording at 1 kHz & faster"}],
        "ranking": [
            {"effect": "thermal_ra", "params": {"ra_tc_per_K": 0.00393}, "shown": "+0.393 %/K",
             "plausible": True, "plausibility": "+0.393 %/K within the plausible 0.33..0.46 %/K",
             "meaning": "copper resistance rises with temperature", "score": 0.77843, "z": 32.448,
             "named": True, "inclusion": 1.0, "identifiable": True},
            {"effect": "current_offset", "params": {"i_offset_A": -0.0161}, "shown": "-16.1 mA",
             "plausible": True, "plausibility": "-16.1 mA within the plausible -50..50 mA",
             "meaning": "DC offset of the current channel", "score": 0.0811, "z": 13.41,
             "named": True, "inclusion": None, "identifiable": True},
            {"effect": "brush_drop", "params": {"brush_V": -1.05}, "shown": "-1.05 V", "plausible": False,
             "plausibility": "-1.05 V outside the plausible 0.05..2.5 V", "meaning": "contact drop <brushes>",
             "score": 0.0034, "z": 7.3, "named": False, "inclusion": 0.0, "identifiable": True},
            {"effect": "inductance", "params": {}, "plausible": False,
             "plausibility": "not identifiable on these recordings", "meaning": "La di/dt",
             "score": 0.0, "z": None, "named": False, "inclusion": None, "identifiable": False},
        ],
        "verdict": "Missing: thermal_ra (+0.393 %/K) & current_offset <-16.1 mA>.",
        "noise_rpm": 2.4199,
        "rmse_rpm": {"before": {"load": 13.921, EVIL: 5.8849, "average": 9.9},
                     "after": {"load": 2.6789, EVIL: float("nan"), "average": 2.68}},
        "rmse_rpm_hybrid": {"before": {"load": 4.354, EVIL: 4.87, "average": 4.61},
                            "after": {"load": 2.081, EVIL: 1.46, "average": 1.77}, "iterations": 150},
        "residual_before": analysis(86.351, False, True),
        "residual_after": analysis(12.549, True, False),
        "steps": [], "thresholds": {"z": np.float64(3.0), "n": np.int64(7), "flags": np.array([True, False]),
                                    "ok": np.bool_(True)},
        "runtime_s": 21.23,
    }


def tiny_png():
    fig, ax = plt.subplots(figsize=(2, 1))
    ax.plot([0, 1], [0, 1])
    return reports.png(fig)


def diagnosis_figures():
    uri = tiny_png()
    return {k: uri for k in ("overlays", "where", "residual_before", "residual_after")}


# ---------------------------------------------------------------- what the pages showed before

TRAINING_TABLE = [
    ["condition", "M1", "M2", "M3"],
    ["sweep", "85.42", "4.13", "2.51"],
    ["load", "362.42", "13.92", "13.99"],
    [EVIL, "12.00", "12.00", "3.00"],
    ["average", "153.28", "10.02", "6.50"],
]
TRAINING_TEXT = (
    "Report <T> n & <b>m</b> RMSE on the held-out test parts (RPM) condition M1 M2 M3 sweep 85.42 4.13 2.51 "
    "load 362.42 13.92 13.99 " + EVIL + " 12.00 12.00 3.00 average 153.28 10.02 6.50 "
    "In bold green : the lowest RMSE of its row. lookup: the mean training speed of the nearest training operating "
    "point, memory alone with no physics; a model close to it on the training recordings and far from it on new ones "
    "has memorised them. In the plots, each model has its own panel with the encoder drawn over it; a long recording "
    "is drawn as the means of stretches of time with the band of their rows; where M3's panel looks like M2's, M3 "
    "equals M2 (the novelty gate faded the correction out, or the observer fell back to physics). "
    "Residual clamp active on sweep 0.0 %, load 1.2 %, " + EVIL + " 50.0 %; physics fallback on sweep 0.1 %, "
    "load 0.0 %, " + EVIL + " 25.0 % of the scored samples. "
    "RMSE over every scored row with an encoder reading; rows removed by the glitch filter before scoring: "
    "sweep 3 of 660, " + EVIL + " 0 of 12. Warning: Ra & Ke <fitted> at the bound sweep")

DIAGNOSIS_TABLES = [
    [["model", "load", EVIL, "average"],
     ["physics, before", "13.92", "5.88", "9.90"],
     ["physics, after + thermal_ra, current_offset", "2.68", "–", "2.68"],
     ["hybrid, before", "4.35", "4.87", "4.61"],
     ["hybrid, after", "2.08", "1.46", "1.77"]],
    [["effect", "named", "score", "z", "inclusion", "fitted parameter", "plausibility", "meaning"],
     ["thermal_ra", "missing", "0.778", "32.4", "100 %", "+0.393 %/K",
      "+0.393 %/K within the plausible 0.33..0.46 %/K", "copper resistance rises with temperature"],
     ["current_offset", "missing", "0.081", "13.4", "–", "-16.1 mA", "-16.1 mA within the plausible -50..50 mA",
      "DC offset of the current channel"],
     ["brush_drop", "–", "0.003", "7.3", "0 %", "-1.05 V", "-1.05 V outside the plausible 0.05..2.5 V",
      "contact drop <brushes>"],
     ["inductance", "unseen", "0.000", "–", "–", "–", "not identifiable on these recordings", "La di/dt"]],
]
DIAGNOSIS_TEXT = " ".join([
    "Diagnosis: where the physics model fails, and what is missing",
    "Recordings: load (597 rows), " + EVIL + " (12 rows). Ra = 4.5 ohm (log metadata ra_ohm).",
    "Model under test: M2 (plain). Held-out rows: the last 20 % of each recording. Runtime 21.2 s.",
    "Verdict. Missing: thermal_ra (+0.393 %/K) & current_offset <-16.1 mA>.",
    "Not identifiable on these recordings (cannot be seen, whatever their size): inductance: needs a recording "
    "at 1 kHz & faster.",
    "Error before and after adding the missing effects (RMSE on the test parts, RPM)",
    "model load " + EVIL + " average physics, before 13.92 5.88 9.90 physics, after + thermal_ra, current_offset "
    "2.68 – 2.68 hybrid, before 4.35 4.87 4.61 hybrid, after 2.08 1.46 1.77",
    "Noise level of the residual (white part, from row-to-row differences): 2.42 RPM.",
    "Hybrid: (16, 8) network retrained on top of each physics model for 150 epochs (hpddo train trains 2000).",
    "Candidate effects, ranked effect named score z inclusion fitted parameter plausibility meaning",
    "thermal_ra missing 0.778 32.4 100 % +0.393 %/K +0.393 %/K within the plausible 0.33..0.46 %/K copper "
    "resistance rises with temperature",
    "current_offset missing 0.081 13.4 – -16.1 mA -16.1 mA within the plausible -50..50 mA DC offset of the "
    "current channel",
    "brush_drop – 0.003 7.3 0 % -1.05 V -1.05 V outside the plausible 0.05..2.5 V contact drop <brushes>",
    "inductance unseen 0.000 – – – not identifiable on these recordings La di/dt",
    "score: share of the held-out mean squared error of the model under test that the effect removes (at its "
    "step of the forward selection; for effects not named, added to the final model). z: that gain in standard "
    "errors of what noise would give. inclusion: share of bootstrap resamples of the training rows' operating "
    "points in which the effect is named (naming does not depend on it). Held out: the last 20 % of each recording.",
    "Effects that these recordings cannot tell apart current_offset / brush_drop (regressors correlated "
    "r = -1.00 once Ke is fitted): record rows at zero current <coasting>.",
    "Estimate against encoder Dashed line: the chronological 80/20 split; only the rows after it are scored.",
    "Where the squared error sits (model under test) Is the residual noise?",
    "model under test : held-out MSE 86.35 RPM², noise 5.85 RPM²; Ljung-Box Q = 2353.2 over 20 lags, "
    "p = 0.0000; 100 % of lags outside the 95 % band: not white. Correlates outside their band: speed (+0.68), "
    "I <A> (-0.53).",
    "after adding the missing effects : held-out MSE 12.55 RPM², noise 5.85 RPM²; Ljung-Box Q = 20.0 over 20 "
    "lags, p = 0.4596; 0 % of lags outside the 95 % band: white. Correlates outside their band: none.",
    "Bands: ±1.96/√N for the autocorrelation; Bartlett's ±1.96 √(Σ r_ee r_uu / N) for the cross-correlations, "
    "so that a slowly varying input is not mistaken for a correlate.",
])


# ---------------------------------------------------------------- reading a page


class Page(HTMLParser):
    """The page's visible text (whitespace collapsed, a space at every tag), its tables
    (rows of cell texts), the classes of each table cell, its images and style blocks."""

    def __init__(self, html):
        super().__init__()
        self.out, self.skip, self.tables, self.cell, self.imgs, self.styles, self.style_attrs = [], 0, [], None, [], [], 0
        self.cell_classes = []
        self.feed(html)
        self.text = re.sub(r"\s+", " ", "".join(self.out)).strip()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.style_attrs += "style" in a
        if tag in ("style", "title"):
            self.skip += 1
            if tag == "style":
                self.styles.append("")
        if tag == "table":
            self.tables.append([])
            self.cell_classes.append([])
        elif tag == "tr":
            self.tables[-1].append([])
            self.cell_classes[-1].append([])
        elif tag in ("td", "th"):
            self.cell = [""]
            self.cell_classes[-1][-1].append(set((a.get("class") or "").split()))
        elif tag == "img":
            self.imgs.append((a.get("alt"), a.get("src")))
        self.out.append(" ")

    def handle_endtag(self, tag):
        if tag in ("style", "title"):
            self.skip -= 1
        if tag in ("td", "th") and self.cell is not None:
            self.tables[-1][-1].append(re.sub(r"\s+", " ", self.cell[0]).strip())
            self.cell = None
        self.out.append(" ")

    def handle_data(self, data):
        if self.cell is not None:
            self.cell[0] += data
        if self.skip:
            if self.styles and self.get_starttag_text().startswith("<style"):
                self.styles[-1] += data
            return
        self.out.append(data)


def training_page(tmp_path):
    est = tmp_path / "estimates"
    est.mkdir()
    estimates().to_csv(est / "sweep.estimates.csv", index=False)
    path = report.write(training_metrics(), est, tmp_path / "report", "Report <T>", ["n & <b>m</b>"])
    return path, path.read_text(encoding="utf-8")


# ---------------------------------------------------------------- the tests


def test_training_page_shows_the_same_table_and_text_with_every_text_escaped(tmp_path):
    path, html = training_page(tmp_path)
    assert path == tmp_path / "report" / "index.html"
    assert not RAW_EVIL.search(html) and "&lt;script&gt;" in html
    assert "<b>m</b>" not in html and "&lt;b&gt;m&lt;/b&gt;" in html
    page = Page(html)
    assert page.tables == [TRAINING_TABLE]
    best = [[c for c, k in zip(row, cls) if "best" in k] for row, cls in zip(page.tables[0], page.cell_classes[0])]
    assert best == [[], ["2.51"], ["13.92"], ["3.00"], ["6.50"]]
    assert page.text == TRAINING_TEXT
    assert [alt for alt, _ in page.imgs] == ["estimates of sweep"]
    assert page.imgs[0][1].startswith("data:image/png;base64,iVBOR")
    assert "<td>sweep</td>" in html  # the first column as test_pipeline's Chromium test finds it


def test_diagnosis_page_shows_the_same_tables_and_text_with_every_text_escaped():
    res = diagnosis_result()
    html = diagnosis_report.page(res, diagnosis_figures())
    assert not RAW_EVIL.search(html) and "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;" in html
    page = Page(html)
    assert page.tables == DIAGNOSIS_TABLES
    assert page.text == DIAGNOSIS_TEXT
    # plausibility colours: green when plausible, red when fitted and implausible, none when unseen
    plaus = [cls[6] for cls in page.cell_classes[1][1:]]
    assert plaus == [{"l", "ok"}, {"l", "ok"}, {"l", "bad"}, {"l"}]
    assert '<b class="bad">missing</b>' in html
    assert 'class="verdict warn"' in html
    assert [alt for alt, _ in page.imgs] == ["overlays", "where", "correlation model under test",
                                            "correlation after adding the missing effects"]


def test_diagnosis_page_without_missing_effects_hybrid_or_confounded_pairs():
    res = diagnosis_result()
    res.update(missing_effects=[], confounded=[], not_identifiable=[], model_effects=["thermal_ra", "v<gain"])
    del res["rmse_rpm_hybrid"]
    page = Page(diagnosis_report.page(res, diagnosis_figures()))
    assert "Model under test: M2 + thermal_ra, v<gain." in page.text
    assert "Hybrid:" not in page.text and "cannot tell apart" not in page.text
    assert "Not identifiable" not in page.text
    assert [r[0] for r in page.tables[0]] == ["model", "physics, before", "physics, after (nothing added)"]


def test_diagnosis_write_renders_the_page_and_the_unchanged_json(tmp_path, monkeypatch):
    res = diagnosis_result()
    figs = diagnosis_figures()
    monkeypatch.setattr("hpddo.reports.diagnosis.figures", lambda r, plot: figs)
    diagnosis_report.write(tmp_path, res, plot=None)
    assert Page((tmp_path / "index.html").read_text(encoding="utf-8")).tables == DIAGNOSIS_TABLES

    def default(o):  # what the f-string report converted, so the JSON stays byte for byte
        if isinstance(o, np.ndarray):
            return o.tolist()
        return o.item()
    # byte for byte, but a number that is not finite is JSON's null (benchlog.json_text), not NaN
    want = json.dumps(res, indent=1, default=default) + "\n"
    assert "NaN" in want
    assert (tmp_path / "diagnosis.json").read_text() == re.sub(r"(?<=: )(NaN|-?Infinity)(?=,?\n)", "null", want)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["diagnosis.json", "index.html"]


def test_both_pages_embed_the_one_stylesheet_and_no_inline_styles(tmp_path):
    _, training = training_page(tmp_path)
    diagnosis = diagnosis_report.page(diagnosis_result(), diagnosis_figures())
    for html in (training, diagnosis):
        page = Page(html)
        assert [s.strip() for s in page.styles] == [reports.css().strip()]
        assert page.style_attrs == 0
        assert html.startswith("<!doctype html>") and '<meta charset="utf-8">' in html


def test_png_returns_a_data_uri_and_closes_the_figure():
    plt.close("all")
    uri = tiny_png()
    assert uri.startswith("data:image/png;base64,iVBORw0KGgo") and plt.get_fignums() == []
    fig, _ = plt.subplots()
    fig.savefig = None  # a figure that cannot be saved is closed all the same
    with pytest.raises(TypeError):
        reports.png(fig)
    assert plt.get_fignums() == []


def test_templates_autoescape_and_ship_in_the_package():
    env = reports.environment()
    assert env.autoescape is True
    names = sorted(p.name for p in reports.TEMPLATES.iterdir())
    assert {"base.html.j2", "training.html.j2", "diagnosis.html.j2"} <= set(names)
    assert env.from_string("{{ x }}").render(x=EVIL) == "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;"
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["hpddo.reports"]
    shipped = {p.relative_to(reports.HERE).as_posix() for g in data for p in reports.HERE.glob(g)}
    wanted = {p.relative_to(reports.HERE).as_posix() for p in reports.HERE.rglob("*")
              if p.is_file() and p.suffix != ".py" and "__pycache__" not in p.parts}
    assert wanted == shipped


def test_both_pages_render_in_headless_chromium(tmp_path):
    if browser.chromium() is None:
        pytest.skip("chromium not installed (scripts/bootstrap.sh --tests installs it)")
    path, _ = training_page(tmp_path)
    diag = tmp_path / "diagnosis"
    diag.mkdir()
    (diag / "index.html").write_text(diagnosis_report.page(diagnosis_result(), diagnosis_figures()),
                                     encoding="utf-8")
    for page, n_img in ((path, 1), (diag / "index.html", 4)):
        png = page.with_suffix(".png")
        seen = browser.render(page, png, height=1600)
        assert seen["console_errors"] == [], seen["console_errors"]
        assert png.stat().st_size > 20000, "the screenshot is (nearly) blank"
        dom = seen["dom"]
        assert dom.count("<img") == n_img and "<script>" not in dom and "&lt;script&gt;" in dom
        assert Page(dom).tables == ([TRAINING_TABLE] if n_img == 1 else DIAGNOSIS_TABLES)


def _command_reports(tmp: pathlib.Path) -> dict:
    """{command: its report page}, each written by the command as a user runs it."""
    from hpddo import cli
    logs = [str(ROOT / "data" / "default" / f"{c}.csv") for c in ("sweep", "load")]
    valid = [str(ROOT / "data" / "validation" / "unseen.csv")]
    assert cli.main(["train", *logs, "--out", str(tmp / "train"), "--epochs", "30", "--quiet"]) == 0
    assert cli.main(["evaluate", "--model", str(tmp / "train"), *valid, "--out", str(tmp / "evaluate"),
                     "--quiet"]) == 0
    assert cli.main(["diagnose", *logs, "--out", str(tmp / "diagnose"), "--bootstrap", "0", "--no-hybrid",
                     "--quiet"]) == 0
    assert cli.main(["compare", *logs, "--validation", *valid, "--out", str(tmp / "compare"), "--quick",
                     "--epochs", "20", "--quiet"]) == 0
    return {"train": tmp / "train" / "report" / "index.html", "evaluate": tmp / "evaluate" / "report" / "index.html",
            "diagnose": tmp / "diagnose" / "index.html", "compare": tmp / "compare" / "report" / "index.html"}


@pytest.mark.slow
def test_every_commands_report_loads_with_its_plots_in_headless_chromium(tmp_path):
    """What each command that produces figures writes beside its JSON, opened as a person
    would open it: it loads, its plots are there, the console is clean."""
    if browser.chromium() is None:
        pytest.skip("chromium not installed (scripts/bootstrap.sh --tests installs it)")
    for command, page in _command_reports(tmp_path).items():
        assert page.is_file(), f"hpddo {command} wrote no report"
        png = tmp_path / f"{command}.png"
        seen = browser.render(page, png, height=1600)
        assert seen["console_errors"] == [], (command, seen["console_errors"])
        assert png.stat().st_size > 20000, f"hpddo {command}: the screenshot is (nearly) blank"
        assert seen["dom"].count("<img") >= 1, f"hpddo {command}: no plot in the report"
