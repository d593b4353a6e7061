"""The comparison's settings and constants: the architectures, feature sets, the paper's figures quoted beside ours."""
from __future__ import annotations

import dataclasses

from ...model import network
from ... import resource_root


TOOL = "compare"


SOURCE = resource_root() / "host" / "compare"


#: The architectures of Table 9, as in the paper.
ARCHITECTURES = ((8,), (16,), (32,), (64,), (16, 8), (32, 16), (64, 32), (128, 64))


QUICK_ARCHITECTURES = ((8,), (16, 8))


QUICK_EPOCHS = 60   # --quick: epochs of every network (the full comparison: 2000, Table 2)


CV_FOLDS = 5


LOCKSTEP_PAD_MAX = 64  # single networks with no layer wider train padded together (Trainer)


#: Feature sets of Table 10: columns of train.FEATURES [V, I, n_M2, I(t-1), n_M2(t-1)].
FEATURE_SETS = {"full": (0, 1, 2, 3, 4), "without lags": (0, 1, 2), "without physics feature n_M2": (0, 1, 3, 4)}


NN_FEATURES = ["v_V", "i_A", "i_A_lag1", "v_V_lag1"]


EQ26_TOLERANCE_RPM = 1e-3  # float32 rounding of the board's sums (a few ulp of a speed of hundreds of RPM)


#: The paper's figures (RPM), quoted beside ours; not measured here.
PAPER = {
    "table7": {"M1": {"sweep": 114.46, "load": 473.80, "long": 449.74, "average": 346.00},
               "M2": {"sweep": 4.57, "load": 9.57, "long": 7.62, "average": 7.25},
               "EKF": {"sweep": 13.30, "load": 8.88, "long": 6.29, "average": 9.49},
               "SMO": {"sweep": 13.55, "load": 10.24, "long": 8.88, "average": 10.89},
               "pure NN": {"sweep": 12.88, "load": 3.82, "long": 4.73, "average": 7.14},
               "M3": {"sweep": 4.19, "load": 3.51, "long": 4.63, "average": 4.11}},
    "table8": {"shuffled 5-fold CV": {"sweep": 6.10, "load": 5.84, "long": 4.85, "average": 5.60},
               "chronological 80/20": {"sweep": 4.19, "load": 3.51, "long": 4.63, "average": 4.11}},
    "table9": {"(8)": [57, 0.2, 5.82, 4.23, 4.62, 4.89], "(16)": [113, 0.4, 4.36, 4.01, 4.62, 4.33],
               "(32)": [225, 0.9, 4.69, 3.94, 4.62, 4.42], "(64)": [449, 1.8, 4.19, 3.83, 4.62, 4.21],
               "(16, 8)": [241, 0.9, 3.88, 3.84, 4.62, 4.11], "(32, 16)": [737, 2.9, 4.90, 3.92, 4.62, 4.48],
               "(64, 32)": [2497, 9.8, 4.24, 3.87, 4.62, 4.24], "(128, 64)": [9089, 35.5, 4.19, 3.51, 4.63, 4.11]},
    "table9_columns": ["params", "memory_kB", "sweep", "load", "long", "average"],
    "table10": {"full": {"sweep": 4.19, "load": 3.51, "long": 4.63, "average": 4.11},
                "without lags": {"sweep": 4.30, "load": 4.29, "long": 4.61, "average": 4.40},
                "without physics feature n_M2": {"sweep": 7.53, "load": 3.94, "long": 4.64, "average": 5.37}},
    "ood": {"M2 (physics only)": {"sweep": 9.81},
            "unconstrained": {"sweep": 13.95, "load": 5.76, "long": 5.02, "average": 8.24},
            "clamped": {"sweep": 10.32, "average": 7.08}, "clamp_rpm": 20.9, "clamped_share_average": 0.045},
}


@dataclasses.dataclass
class CompareConfig:
    hidden: tuple = (16, 8)
    effects: tuple = ()
    ra_ohm: float | None = None
    seed: int = 1
    quick: bool = False
    workers: int = 2
    glitch_filter: bool = True
    progress: bool = True
    command: str = "hpddo compare"
    epochs_given: int | None = None  # --epochs; None: QUICK_EPOCHS with --quick, else network's default
    # ripple counting as a peer (issue 23 item 6): the motor's ripples per revolution and gear
    # ratio; None: no ripple rows. The alone row's prior: Ke (None: calibrated from the ripple),
    # or a trained model's M2 (hpddo.ripple.prior.ModelPrior, --prior-model); the current floor
    # (None: hpddo.ripple.options.Options' default)
    ripples_per_rev: int | None = None
    gear_ratio: float | None = None
    ripple_ke_vs_per_rad: float | None = None
    ripple_floor_A: float | None = None
    ripple_prior_model: object | None = None

    @property
    def epochs(self) -> int:
        if self.epochs_given is not None:
            return self.epochs_given
        return QUICK_EPOCHS if self.quick else network.AdamConfig.max_iter

    @property
    def architectures(self) -> tuple:
        archs = QUICK_ARCHITECTURES if self.quick else ARCHITECTURES
        return archs if tuple(self.hidden) in archs else archs + (tuple(self.hidden),)


EQ26_FLOAT64_TOLERANCE_RPM = 1e-9  # float64 rounding where the clamp is reached exactly (~1e-14 RPM)


def param_count(hidden, n_in: int = 5) -> int:
    sizes = (n_in, *hidden, 1)
    return int(sum(a * b + b for a, b in zip(sizes[:-1], sizes[1:])))


def label(hidden) -> str:
    return "(" + ", ".join(map(str, hidden)) + ")"
