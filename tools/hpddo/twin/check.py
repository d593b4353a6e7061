"""M1 / M2 check of a recording, as the paper computes them (sections 3.6.2-3.6.3, 4.4).

* M1: n = (V - I Ra) / Ke_nameplate * 60 / 2pi, Ke_nameplate = 12 V / 1000 RPM = 0.114.
* M2: Ke identified by eq. 20, Ke = mean((V - I Ra) / (rpm_ref * 0.10472)) over the
  rows with rpm_ref > 10 of the first 80 % of the recording (chronological split);
  n = (V - I Ra) / Ke * 60 / 2pi.
* RMSE against rpm_ref over the last 20 %.

``exclude`` drops rows (e.g. the glitches listed in the truth sidecar, i.e. the
result after an ideal glitch filter); ``ke`` fixes Ke instead of identifying it
(e.g. the twin's true Ke, to see an effect's bias without the identification
absorbing part of it). This is a check for the twin, not the project's pipeline.
"""
from __future__ import annotations

import math

import numpy as np

RA_OHM = 4.50
KE_NAMEPLATE = 12.0 / (1000.0 * 2 * math.pi / 60.0)
RPM_PER_RADS = 60.0 / (2 * math.pi)


def split_index(n, train_frac=0.8):
    return int(math.floor(n * train_frac))


def identify_ke(v, i, rpm, ra=RA_OHM, min_rpm=10.0):
    m = rpm > min_rpm
    return float(np.mean((v[m] - i[m] * ra) / (rpm[m] * 0.10472)))


def pooled_ke(dfs, excludes=None, ra=RA_OHM, train_frac=0.8):
    """Paper section 4.3: one Ke by eq. 20 over the training rows of every recording
    together (sweep, load and long alike), as the project's pipeline identifies it."""
    v, i, rpm = [], [], []
    for k, df in enumerate(dfs):
        keep = np.ones(len(df), dtype=bool)
        if excludes is not None:
            keep[np.asarray(list(excludes[k]), dtype=int)] = False
        keep[split_index(len(df), train_frac):] = False
        v.append(df["v_V"].to_numpy(float)[keep])
        i.append(df["i_A"].to_numpy(float)[keep])
        rpm.append(df["rpm_ref"].to_numpy(float)[keep])
    return identify_ke(np.concatenate(v), np.concatenate(i), np.concatenate(rpm), ra)


def m_errors(df, ra=RA_OHM, ke=None, exclude=None, train_frac=0.8):
    """Dict with ke_m2, rmse_m1, rmse_m2, bias_m2 (mean of n_M2 - rpm_ref) on the test part."""
    v = df["v_V"].to_numpy(float)
    i = df["i_A"].to_numpy(float)
    rpm = df["rpm_ref"].to_numpy(float)
    keep = np.ones(len(v), dtype=bool)
    if exclude is not None:
        keep[np.asarray(list(exclude), dtype=int)] = False
    cut = split_index(len(v), train_frac)
    tr = keep.copy()
    tr[cut:] = False
    te = keep.copy()
    te[:cut] = False
    ke_m2 = identify_ke(v[tr], i[tr], rpm[tr], ra) if ke is None else float(ke)
    emf = v - i * ra
    n_m1 = emf / KE_NAMEPLATE * RPM_PER_RADS
    n_m2 = emf / ke_m2 * RPM_PER_RADS
    e2 = n_m2[te] - rpm[te]
    e1 = n_m1[te] - rpm[te]
    return {
        "ke_m2": ke_m2,
        "rmse_m1": float(np.sqrt(np.mean(e1 ** 2))),
        "rmse_m2": float(np.sqrt(np.mean(e2 ** 2))),
        "bias_m2": float(np.mean(e2)),
        "n_test": int(te.sum()),
    }


def m2_error_series(df, ke, ra=RA_OHM):
    """n_M2 - rpm_ref per row for a fixed ke."""
    emf = df["v_V"].to_numpy(float) - df["i_A"].to_numpy(float) * ra
    return emf / ke * RPM_PER_RADS - df["rpm_ref"].to_numpy(float)
