"""The native competitors (host/compare): the EKF and the sliding-mode observer, tuned on the training rows only, and the pure network replayed in float32."""
from __future__ import annotations

import atexit
import dataclasses
import json
import os
import pathlib
import shutil
import subprocess
import tempfile
import threading
import numpy as np

from ...evaluation import replay
from ...logs import dataset
from ...model import network
from ...logs.errors import InputError
from . import ripple_peer
from .config import SOURCE


_build_lock = threading.Lock()


_exe: pathlib.Path | None = None


def observers_exe() -> pathlib.Path:
    """compare_observers, built once per process with CMake (removed at exit)."""
    global _exe
    with _build_lock:
        if _exe is None:
            if shutil.which("cmake") is None:
                raise replay.ToolchainError("cmake not found, needed to build the observers of hpddo compare: "
                                            f"{replay.INSTALL}")
            d = pathlib.Path(tempfile.mkdtemp(prefix="hpddo-compare-"))
            pid = os.getpid()
            atexit.register(lambda: os.getpid() == pid and shutil.rmtree(d, ignore_errors=True))
            replay._cmake(["-S", str(SOURCE), "-B", str(d)], "configuring the observers of hpddo compare")
            replay._cmake(["--build", str(d)], "building the observers of hpddo compare")
            _exe = d / "compare_observers"
    return _exe


def training_log(rec: dataset.Recording, path: pathlib.Path) -> pathlib.Path:
    """The training rows of rec alone as a bench log: all the tuner is given."""
    part = dataclasses.replace(rec, df=rec.df.iloc[: rec.n_train].reset_index(drop=True))
    part = dataclasses.replace(part, n_train=part.n)
    meta = dict(rec.meta)
    meta["condition"] = rec.name
    meta["note"] = f"training rows 0..{rec.n_train - 1} of {rec.source.name} (cleaned), for tuning"
    meta["split_row"] = str(part.n)
    from ...logs import benchlog
    return benchlog.write_log(path, part.df, meta, exact=True)  # the numbers it was read with


def tune_observers(jobs: dict, work: pathlib.Path, coarse: bool = False, ripple: dict | None = None) -> dict:
    """Friction and the EKF's and SMO's parameters for each job {name: (train_recs, m2)},
    tuned on the training rows of train_recs only: each recording's training part is
    written to work/<name>/ as a log of its own, and that is all the tuner reads. ripple
    ({recording name: ripple_peer.RippleSpeeds}): the counts of those training rows beside
    them (withheld from every other block of rows, ripple_peer.write_speeds), and the EKF with
    the count as a second measurement tuned too ("ekf_ripple"). The
    tuners run as parallel processes. Returns {name: the tuner's JSON}."""
    procs = {}
    for name, (train_recs, m2) in jobs.items():
        d = work / dataset.safe_name(name)
        d.mkdir(parents=True, exist_ok=True)
        kept = [r for r in train_recs if r.n_train > 1]
        logs = [training_log(r, d / f"{r.file_stem}.train.csv") for r in kept]
        if ripple is not None:
            for r, p in zip(kept, logs):
                ripple_peer.write_speeds(ripple[r.name], d / f"{p.stem}.ripple_speed.csv", rows=r.n_train,
                                         for_tuning=True)
        procs[name] = subprocess.Popen([str(observers_exe()), "tune", "--ke", repr(m2.ke_vs_per_rad), "--ra",
                                        repr(m2.ra_ohm), *(["--coarse"] if coarse else []),
                                        *(["--ripple", str(d)] if ripple is not None else []), *map(str, logs)],
                                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out = {}
    for name, pr in procs.items():
        stdout, stderr = pr.communicate()
        if pr.returncode != 0:
            raise InputError(f"tuning the observers ({name}) failed: {stderr.strip()}")
        out[name] = json.loads(stdout)
    return out


def write_mlp(scaler: network.Scaler, net: network.Network, path: pathlib.Path) -> pathlib.Path:
    """The pure network for compare_observers (its read_mlp), floats to 9 digits."""
    sizes = [len(scaler.mean_)] + [w.shape[1] for w in net.coefs_]
    f = lambda a: " ".join(f"{v:.9g}" for v in np.asarray(a, float).ravel())
    lines = [f"hpddo-mlp 1 {len(sizes)}", " ".join(map(str, sizes)), f(scaler.mean_), f(scaler.scale_)]
    for w, b in zip(net.coefs_, net.intercepts_):
        lines += [f(np.asarray(w).T), f(b)]
    path.write_text("\n".join(lines) + "\n")
    return path


def run_observers(tuned: dict, recs, work: pathlib.Path, mlp: pathlib.Path | None, ripple: dict | None = None) -> list:
    """EKF, SMO and pure network estimates (rpm) of every row of recs: [{method: array}];
    ripple ({recording name: ripple_peer.RippleSpeeds}): also the EKF with the ripple count as
    a second measurement (ripple_peer.EKF)."""
    import pandas as pd
    (work / "logs").mkdir(parents=True, exist_ok=True)
    (work / "estimates").mkdir(parents=True, exist_ok=True)
    logs = [dataset.write_clean(r, work / "logs" / f"{r.file_stem}.csv") for r in recs]
    m, e, s = tuned["motor"], tuned["ekf"], tuned["smo"]
    j = lambda *v: ",".join(repr(float(x)) for x in v)
    cmd = [str(observers_exe()), "run", "--motor", j(m["ke_vs_per_rad"], m["ra_ohm"], m["b_nms_per_rad"], m["tc_nm"]),
           "--ekf", j(e["j_kgm2"], e["q_w"], e["q_t"], e["r_A2"]), "--smo", j(s["k_V"], s["phi_A"], s["tau_s"]),
           "--out-dir", str(work / "estimates")]
    if mlp is not None:
        cmd += ["--mlp", str(mlp)]
    if ripple is not None:
        (work / "ripple").mkdir(parents=True, exist_ok=True)
        for r, p in zip(recs, logs):
            ripple_peer.write_speeds(ripple[r.name], work / "ripple" / f"{p.stem}.ripple_speed.csv")
        er = tuned["ekf_ripple"]
        cmd += ["--ripple", str(work / "ripple"), "--ekf-ripple", j(er["j_kgm2"], er["q_w"], er["q_t"], er["r_A2"])]
    res = subprocess.run(cmd + [str(p) for p in logs], capture_output=True, text=True)
    if res.returncode != 0:
        raise InputError(f"replaying the observers failed: {res.stderr.strip()}")
    out = []
    for r, p in zip(recs, logs):
        df = pd.read_csv(work / "estimates" / f"{p.stem}.observers.csv")
        if len(df) != r.n:
            raise RuntimeError(f"compare_observers wrote {len(df)} rows for {r.n} of {r.name}")
        out.append({"EKF": df["rpm_ekf"].to_numpy(float), "SMO": df["rpm_smo"].to_numpy(float),
                    "pure NN": df["rpm_nn"].to_numpy(float),
                    **({ripple_peer.EKF: df["rpm_ekf_ripple"].to_numpy(float)} if ripple is not None else {})})
    return out
