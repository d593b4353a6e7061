"""The lookup baseline: what memory alone scores.

For every operating point of the training rows, a (duty, load) pair, the mean encoder
speed of its training rows; a row is "estimated" by the mean of the nearest training
operating point: the same load state with the nearest duty, or the nearest duty over
every load where the load state never occurred in training. It knows no physics: on the
paper's chronological split (steady operating points seen in training) it scores well,
and on operating points absent from training it shows what memory is worth. A model
that does not beat it there has learned nothing a table would not.

The table is part of a trained model (lookup.json beside the model header), so that
`hpddo evaluate` scores it on new recordings with the model.
"""
from __future__ import annotations

import dataclasses
import json
import math
import pathlib

import numpy as np

FILE = "lookup.json"
DUTY_DIGITS = 4  # duty is logged to 1e-4; a PWM command is one of a few hundred levels


@dataclasses.dataclass(frozen=True)
class Lookup:
    """Mean training speed per operating point, sorted by (load, duty)."""

    duty: np.ndarray   # per point
    load: np.ndarray   # per point (int)
    rpm: np.ndarray    # mean rpm_ref of its training rows
    rows: np.ndarray   # training rows behind each mean

    @staticmethod
    def fit(recs) -> "Lookup":
        """From the training rows (the first n_train rows) of recordings with rpm_ref."""
        sums: dict = {}
        for r in recs:
            if "rpm_ref" not in r.df:
                continue
            part = r.df.iloc[: r.n_train]
            ref = part["rpm_ref"].to_numpy(float)
            duty = np.round(part["duty"].to_numpy(float), DUTY_DIGITS)
            load = part["load"].to_numpy(np.int64) if "load" in part else np.zeros(len(part), np.int64)
            for d, k, v in zip(duty.tolist(), load.tolist(), ref.tolist()):
                if math.isfinite(v):
                    sums.setdefault((int(k), float(d)), []).append(v)
        keys = sorted(sums)
        return Lookup(duty=np.array([d for _, d in keys], float), load=np.array([k for k, _ in keys], np.int64),
                      # fsum: exactly rounded, the same on every CPU
                      rpm=np.array([math.fsum(sums[key]) / len(sums[key]) for key in keys], float),
                      rows=np.array([len(sums[key]) for key in keys], np.int64))

    def predict(self, duty, load) -> np.ndarray:
        """The mean training speed of the nearest training operating point of each row;
        NaN when the table is empty."""
        duty = np.round(np.asarray(duty, float), DUTY_DIGITS)
        load = np.asarray(load, np.int64)
        out = np.full(len(duty), np.nan)
        if not len(self.rpm):
            return out
        for k in np.unique(load):
            rows = load == k
            pts = np.flatnonzero(self.load == k)
            if not len(pts):
                pts = np.arange(len(self.rpm))
            dist = np.abs(duty[rows, None] - self.duty[None, pts])
            out[rows] = self.rpm[pts[np.argmin(dist, axis=1)]]  # ties: the first, lower (load, duty)
        return out

    def predict_rows(self, rec) -> np.ndarray:
        """predict() for every row of a recording (load 0 where the log has none)."""
        df = rec.df
        load = df["load"].to_numpy(np.int64) if "load" in df else np.zeros(len(df), np.int64)
        return self.predict(df["duty"].to_numpy(float), load)

    def to_json(self) -> str:
        points = [{"load": int(k), "duty": float(d), "rpm": float(f"{v:.9g}"), "rows": int(n)}
                  for k, d, v, n in zip(self.load, self.duty, self.rpm, self.rows)]
        return json.dumps({"what": "mean encoder speed of the training rows per operating point (duty, load); "
                                   "hpddo.evaluation.baseline", "points": points}, indent=1) + "\n"

    @staticmethod
    def read(path) -> "Lookup":
        from ..logs.errors import InputError
        try:
            pts = json.loads(pathlib.Path(path).read_text(encoding="utf-8"))["points"]
            return Lookup(duty=np.array([float(p["duty"]) for p in pts], float),
                          load=np.array([int(p["load"]) for p in pts], np.int64),
                          rpm=np.array([float(p["rpm"]) for p in pts], float),
                          rows=np.array([int(p["rows"]) for p in pts], np.int64))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise InputError(f"{path}: not a lookup table of hpddo train ({exc})") from None
