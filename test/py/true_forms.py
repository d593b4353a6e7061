"""The bench twin's own law of an effect carried in a form outside the library, as a model
of the speed: the true model against which the physics after naming is measured
(test_diagnosis_forms.py; docs/diagnosis-forms.md, Forms outside the library). Ke and the
effect's size are fitted on the diagnosis' training rows in the twin's true form (the
form's constants known), Ra at the twin's; scored on the diagnosis' held-out rows as
core.diagnose scores the physics after naming."""
import numpy as np
from scipy.optimize import least_squares

from hpddo.diagnosis import core
from hpddo.model import physics as ph
from hpddo.twin import params as tp
from hpddo.twin import protocols


def _law(effect: str, form: str, bench, r, ke: float, c: float) -> np.ndarray:
    """n (RPM) of rows r under the twin's law: effect `effect` in form `form`, size c (SI).
    A channel's offset in its form (tp.offset_share: "case", following the case's rise
    above the protocol's ambient; the case read by the log's temp_C)."""
    v, i = r.v, r.i
    if effect in ("current_offset", "v_offset"):
        ambient = protocols.bench_for(r.rec.name, bench).ambient_C
        off = c * tp.offset_share(form, r.rec.df["t_s"].to_numpy(float), r.temp, ambient)
        v, i = (v - off, i) if effect == "v_offset" else (v, i - off)
        return (v - bench.ra_ohm * i) / ke * ph.RPM_PER_RAD_S
    a = np.abs(i)
    ra = bench.ra_ohm
    if effect == "brush_drop":
        drop = c * np.sign(i) * np.array([tp.brush_share(form, x) for x in a])
        return (v - ra * i - drop) / ke * ph.RPM_PER_RAD_S
    if effect == "saturation":
        sat = np.array([tp.saturation_shape(form, x) for x in a])
        return (v - ra * i) / (ke * (1.0 - c * sat)) * ph.RPM_PER_RAD_S
    raise ValueError(f"no true model of {effect} here")


def true_rmse(paths, bench, effect: str) -> tuple[float, dict]:
    """(held-out RMSE averaged over the recordings, RPM, as Diagnosis rmse_rpm["after"]
    ["average"]; the fitted {"ke_vs_per_rad", "size"}) of the twin's law for `effect` in
    the bench's form, fitted on the diagnosis' training rows."""
    inp = core.load(paths, core.Options(bootstrap=0, hybrid=False))
    form = bench.form(effect)
    rows = inp.rows

    def resid(x):
        out = []
        for r in rows:
            n = _law(effect, form, bench, r, x[0], x[1])
            e = (r.ref - n)[r.train]
            out.append(np.where(np.isfinite(e), e, 1e4))
        return np.concatenate(out)

    size0 = bench.effect_si(effect)
    fit = least_squares(resid, [inp.m2.ke_vs_per_rad, size0], x_scale=[0.3, abs(size0) or 1.0])
    res = [r.ref - _law(effect, form, bench, r, *fit.x) for r in rows]
    return core._rmse_by_condition(rows, res)["average"], {"ke_vs_per_rad": float(fit.x[0]), "size": float(fit.x[1])}


def law_rpm(bench, effect: str, r, fitted: dict) -> np.ndarray:
    """n (RPM) of rows r under the twin's law for `effect` with the sizes true_rmse fitted."""
    return _law(effect, bench.form(effect), bench, r, fitted["ke_vs_per_rad"], fitted["size"])
