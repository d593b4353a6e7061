"""diagnosis/noise.py: where the white part of a time series' held-out residual cannot be measured (fewer than
analysis.MIN_DIFFERENCES consecutive labelled rows that differ: an encoder read on every other row), the floor is
what the model leaves out of fold, as on a table that repeats no operating point, and the verdict says why;
never a NaN floor. The diagnosis of such a log printed "noise floor nan RPM: measured nan RPM" under "Nothing
missing: the residual is consistent with measurement noise" (found by a fuzzing helper)."""
import math

from hpddo.diagnosis import core
from hpddo.logs import benchlog
from hpddo.schema import ROOT


def test_a_floor_that_cannot_be_measured_is_the_models_own_and_said_so(tmp_path):
    log = benchlog.read_log(ROOT / "data" / "default" / "sweep.csv")
    df = log.df.copy()
    df.loc[df.index % 2 == 1, "rpm_ref"] = float("nan")  # read at half the logger's rate: empty is "not measured"
    path = benchlog.write_log(tmp_path / "sweep.csv", df, log.meta, exact=True)
    res = core.diagnose([path], core.Options(bootstrap=0, hybrid=False)).to_json()
    nf = res["noise_floor"]
    assert math.isfinite(nf["rpm"]) and nf["rpm"] > 0 and nf["from_model"], nf
    assert "fewer than 5 consecutive rows with rpm_ref read differ" in nf["text"], nf["text"]
    assert "nan" not in nf["text"] and "consistent with measurement noise" not in res["verdict"], res["verdict"]
    assert "rows with rpm_ref read differ" in res["verdict"], res["verdict"]


def test_a_white_residual_far_above_the_floor_is_not_called_noise():
    """No effect named, the residual white but 72x the noise variance above the floor: the verdict said "Nothing
    missing: the residual is consistent with measurement noise" while the next-command line said it stays above
    the floor (a fuzzing helper's three twin recordings of different benches). It says what is left; a residual
    within the floor is still noise."""
    from hpddo.diagnosis import verdict
    from hpddo.diagnosis.result import Confounding, ResidualAnalysis, Residuals, Selection

    def said(excess: float) -> str:
        after = ResidualAnalysis(mse=excess + 1.0, noise_var=1.0, excess=excess, whiteness={"white": True},
                                 correlates=[])
        resid = Residuals(after_model=None, res_after=[], before=after, after=after)
        sel = Selection(steps=[], final=None, steps_final=None, missing=[], ranking=[])
        return verdict._verdict(sel, Confounding(groups=[], pairs=[]), resid, 1.0)

    far = said(72.0)
    assert far.startswith("No library effect is named, but the residual is not measurement noise") and "72.0x" in far
    assert "consistent with measurement noise" not in far
    assert said(0.01) == verdict.NOTHING


def test_a_structured_residual_without_a_significant_correlate_says_so():
    """A structured residual (above the floor, not white) whose correlates are all within their bands: the verdict
    printed "Its strongest correlates: ." (a fuzzing helper's short twin sweep). It says none correlates, and
    names the inputs tested; with one significant, it names it."""
    from hpddo.diagnosis import verdict
    from hpddo.diagnosis.result import Confounding, ResidualAnalysis, Residuals, Selection

    corr = [{"input": "I", "peak": 0.1, "peak_lag": 0, "significant": False},
            {"input": "V", "peak": 0.05, "peak_lag": 2, "significant": False}]
    after = ResidualAnalysis(mse=9.0, noise_var=1.0, excess=8.0, whiteness={"white": False}, correlates=corr)
    resid = Residuals(after_model=None, res_after=[], before=after, after=after)
    sel = Selection(steps=[], final=None, steps_final=None, missing=[], ranking=[])
    said = verdict._verdict(sel, Confounding(groups=[], pairs=[]), resid, 1.0)
    assert "correlates: ." not in said and "None of the logged inputs correlates with it beyond its band" in said
    assert "(I, V)" in said, said
    corr[1]["significant"] = True
    assert "Its strongest correlates: V (r = +0.05 at lag 2)." in verdict._verdict(
        sel, Confounding(groups=[], pairs=[]), resid, 1.0)
