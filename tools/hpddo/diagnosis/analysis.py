"""Residual analysis on held-out rows: noise level, whiteness (autocorrelation with its
confidence band, Ljung-Box), cross-correlation with the inputs (with Bartlett bands),
and where the squared error sits (by recording, time, operating point, temperature)."""
from __future__ import annotations

import numpy as np
from scipy import stats
from statsmodels.stats.diagnostic import acorr_ljungbox
from statsmodels.tsa import stattools

MAX_LAG = 20
Z95 = 1.959963984540054
# Scale of the median absolute deviation to a normal's standard deviation. Kept at the
# rounded 1.4826 rather than scipy's scale="normal" (1/Phi^-1(3/4) = 1.482602...): that
# would move the noise floor, and with it every z of the ranking, by 1.5e-6 relative.
MAD_NORMAL = 1.4826


def runs(mask: np.ndarray) -> list[np.ndarray]:
    """Row indices of each contiguous run of True in mask that is longer than two rows."""
    idx = np.flatnonzero(mask)
    if len(idx) < 3:
        return []
    cuts = np.flatnonzero(np.diff(idx) != 1) + 1
    return [c for c in np.split(idx, cuts) if len(c) > 2]


def parts(rows, res, arrays=None, which: str = "test") -> list[np.ndarray]:
    """Contiguous pieces of the held-out (which="test") or training ("train") rows of each
    recording at which the residual res is finite: of the residual itself, or of `arrays`
    (one array per recording, e.g. an input) at the same rows."""
    arrays = res if arrays is None else arrays
    return [a[c] for r, e, a in zip(rows, res, arrays) for c in runs(getattr(r, which) & np.isfinite(e))]


MIN_DIFFERENCES = 5  # robust_noise_var's differences at the least (else NaN: not measured)


def robust_noise_var(e_parts) -> float:
    """Variance of the white part of the residual from first differences within each
    contiguous part: a slow structured error hardly moves from one row to the next, a
    white error of variance s2 gives differences of variance 2 s2. The median absolute
    difference (scaled for a normal) keeps steps and transients from inflating it.
    Differences that are exactly zero are left out: they are repeated readings (a
    tachometer slower than the logger, a table with duplicated rows), which say nothing
    of the noise, and which would otherwise drive the median, and the floor, to zero."""
    diffs = [np.diff(e) for e in e_parts if len(e) > 2]
    d = np.concatenate(diffs) if diffs else np.zeros(0)
    d = d[d != 0.0]
    if len(d) < MIN_DIFFERENCES:
        return float("nan")
    mad = MAD_NORMAL * float(stats.median_abs_deviation(d))
    return float(mad * mad / 2.0)


def acf(x: np.ndarray, max_lag: int = MAX_LAG) -> np.ndarray:
    """Sample autocorrelation at lags 0..max_lag (biased estimator, as system
    identification tools use: statsmodels' acf with adjusted=False); zero at lags the
    series is too short for."""
    x = np.asarray(x, float)
    n = len(x)
    out = np.zeros(max_lag + 1)
    if n < 3 or float(np.dot(x - x.mean(), x - x.mean())) <= 0:
        return out
    k = min(max_lag, n - 1)
    out[: k + 1] = stattools.acf(x, adjusted=False, nlags=k, fft=False)
    return out


def ccf(e: np.ndarray, u: np.ndarray, max_lag: int = MAX_LAG) -> np.ndarray:
    """Cross-correlation of residual e(t) with input u(t - k), k = -max_lag..max_lag
    (statsmodels' ccf, biased, both ways round for the two signs of k)."""
    e = np.asarray(e, float)
    u = np.asarray(u, float)
    n = len(e)
    out = np.zeros(2 * max_lag + 1)
    ec, uc = e - e.mean(), u - u.mean()
    if n < 3 or np.dot(ec, ec) * np.dot(uc, uc) <= 0:
        return out
    k = min(max_lag + 1, n)  # a short part has no pairs beyond lag n - 1
    out[max_lag: max_lag + k] = stattools.ccf(e, u, adjusted=False, fft=False, nlags=k)  # k >= 0
    out[max_lag - k + 1: max_lag + 1] = stattools.ccf(u, e, adjusted=False, fft=False, nlags=k)[::-1]  # k <= 0
    return out


def ccf_band(e: np.ndarray, u: np.ndarray, max_lag: int = MAX_LAG) -> float:
    """95 % band of the cross-correlation under 'e independent of u' (Bartlett's formula:
    the variance of r_eu(k) is sum_j r_ee(j) r_uu(j) / N), so a smooth input does not
    pass as a correlate."""
    n = len(e)
    if n < 3:
        return float("nan")
    ra, rb = acf(e, max_lag), acf(u, max_lag)
    s = 1.0 + 2.0 * float(np.sum(ra[1:] * rb[1:]))
    return Z95 * np.sqrt(max(s, 1.0) / n)


def ljung_box(x: np.ndarray, lags: int = MAX_LAG) -> tuple[float, float]:
    """Ljung-Box Q over lags 1..lags and its p-value (white noise: large p)."""
    n = len(x)
    if n <= lags + 2:
        return float("nan"), float("nan")
    r = acorr_ljungbox(np.asarray(x, float), lags=[lags], return_df=True)
    return float(r["lb_stat"].iloc[0]), float(r["lb_pvalue"].iloc[0])


def whiteness(parts) -> dict:
    """ACF of the pooled held-out residual (parts are contiguous pieces, each centred), its
    95 % band, the share of lags outside it and the Ljung-Box test per part, combined."""
    parts = [np.asarray(p, float) for p in parts if len(p) > MAX_LAG + 2]
    if not parts:
        return {"acf": [], "band": None, "outside": None, "q": None, "p": None, "white": None}
    n = sum(len(p) for p in parts)
    # Pooled ACF: per-part lagged products, summed (no products across parts), each part
    # centred on its own mean. No library function pools parts this way (statsmodels' acf
    # and acorr_ljungbox take one series; concatenating the parts would add products
    # across the cuts and one common mean), so the pooled ACF and its Ljung-Box Q, with
    # the pooled row count as N, are written here.
    num = np.zeros(MAX_LAG + 1)
    den = 0.0
    for p in parts:
        x = p - p.mean()
        den += float(np.dot(x, x))
        for k in range(MAX_LAG + 1):
            num[k] += float(np.dot(x[: len(x) - k], x[k:]))
    r = num / den if den > 0 else np.zeros(MAX_LAG + 1)
    band = Z95 / np.sqrt(n)
    outside = float(np.mean(np.abs(r[1:]) > band))
    q = n * (n + 2) * float(np.sum(r[1:] ** 2 / (n - np.arange(1, MAX_LAG + 1))))
    p = float(stats.chi2.sf(q, MAX_LAG))
    return {"acf": r.tolist(), "band": float(band), "outside": outside, "q": q, "p": p,
            "white": bool(p > 0.001 or outside <= 0.1)}


def correlates(parts_e, parts_u: dict, max_lag: int = MAX_LAG) -> list:
    """Cross-correlation of the residual with each input, the largest |r| and its lag, and
    whether it leaves the 95 % band; the significant ones first, each group by |r| (the
    band of a slowly varying input, duty steps, is wide, but an r of -0.9 outside it says
    more than an r of -0.2 far outside a narrow one: the strength relative to the band is
    reported as "strength")."""
    out = []
    e = np.concatenate([p - p.mean() for p in parts_e]) if parts_e else np.array([])
    for name, parts in parts_u.items():
        u = np.concatenate([p - p.mean() for p in parts])
        if len(u) < 3 or not np.all(np.isfinite(u)) or np.std(u) <= 0:
            continue
        r = ccf(e, u, max_lag)
        band = ccf_band(e, u, max_lag)
        k = int(np.argmax(np.abs(r)))
        out.append({"input": name, "ccf": r.tolist(), "band": band, "peak": float(r[k]),
                    "peak_lag": k - max_lag, "at_lag0": float(r[max_lag]),
                    "significant": bool(abs(r[k]) > band), "strength": float(abs(r[k]) / band) if band > 0 else 0.0})
    out.sort(key=lambda d: (not d["significant"], -abs(d["peak"])))
    return out


def binned_mse(x: np.ndarray, e2: np.ndarray, bins: int = 8) -> dict:
    """Mean squared error in quantile bins of x."""
    ok = np.isfinite(x) & np.isfinite(e2)
    x, e2 = x[ok], e2[ok]
    if len(x) < bins * 3 or np.ptp(x) <= 0:
        return {"edges": [], "mse": [], "count": []}
    edges = np.unique(np.quantile(x, np.linspace(0, 1, bins + 1)))
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
    mse = [float(np.mean(e2[idx == b])) if np.any(idx == b) else float("nan") for b in range(len(edges) - 1)]
    cnt = [int(np.sum(idx == b)) for b in range(len(edges) - 1)]
    return {"edges": edges.tolist(), "mse": mse, "count": cnt}
