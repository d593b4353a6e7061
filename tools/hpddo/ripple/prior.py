"""The back-EMF prior of the ripple's line: M2 without effects, (V - I Ra) / Ke, what it cannot
know at each operating point, its weight on a candidate frequency, and a trained model's M2 as
the prior instead (`ModelPrior`, hpddo ripple --model, --prior-model of --reference ripple)."""
from __future__ import annotations

import dataclasses
import math
import pathlib

import numpy as np

from .options import Options


def m2_prior_rpm(v_V, i_A, ra_ohm: float, ke_vs_per_rad: float):
    """The back-EMF estimate of the output speed, RPM: (V - I Ra) / Ke (M2 without effects)."""
    return (np.asarray(v_V, float) - np.asarray(i_A, float) * ra_ohm) / ke_vs_per_rad * 60.0 / (2 * math.pi)


def m2_prior_sd_rpm(v_V, i_A, ra_ohm: float, ke_vs_per_rad: float, opts: Options):
    """What the back-EMF prior (V - I Ra) / Ke cannot know at each window's operating point, as
    a speed (RPM), below and above it (an array (n, 2)): a voltage the winding does not see.

        below: u / Ke,  u = sqrt(U^2 + (ra_rel Ra I)^2);     above: ra_rel Ra I / Ke

    U (opts.prior_unmodelled_V) is of the order of a brush drop: it only takes voltage from the
    winding, so it only puts the speed below the prior; Ra's error times I (opts.prior_ra_rel)
    goes either way (a winding warmer or colder than when Ra was measured). Beside it the
    likelihood takes Ke's own relative error (opts.prior_rel_sd) times the candidate's speed
    (`prior_like`). Against the back-EMF E = V - I Ra these voltages are small at high speed
    (a strong prior) and a large share of E at low speed and high current (a weak one)."""
    i = np.abs(np.asarray(i_A, float))
    u_ra = opts.prior_ra_rel * ra_ohm * i
    u = np.hypot(opts.prior_unmodelled_V, u_ra)
    to_rpm = 60.0 / (2 * math.pi) / ke_vs_per_rad
    return np.stack([u * to_rpm, u_ra * to_rpm], axis=-1)


def prior_like(g, f_prior, sd_below, sd_above, rel_sd):
    """The prior's weight at the candidate frequencies g (Hz) and their distance from it in sd:
    z = (g - f_prior) / sqrt(sd_side^2 + (rel_sd g)^2), a voltage error (sd_below under the prior,
    sd_above over it, in Hz) and Ke's relative error on the candidate's own back-EMF. Ones and
    zeros without a prior."""
    g = np.asarray(g, float)
    if not np.isfinite(f_prior):
        return np.ones_like(g), np.zeros_like(g)
    d = g - f_prior
    z = d / np.sqrt(np.where(d < 0, sd_below, sd_above) ** 2 + (rel_sd * g) ** 2)
    return np.exp(-0.5 * z ** 2), z


def rpm_per_amp(ra_ohm: float, ke_vs_per_rad: float) -> float:
    """Ra / Ke in RPM per A: the speed a change of the armature current costs at constant voltage."""
    return ra_ohm / ke_vs_per_rad * 60.0 / (2 * math.pi)


@dataclasses.dataclass(frozen=True)
class ModelPrior:
    """A trained model's identified M2 as the back-EMF prior (hpddo ripple --model, --prior-model of
    --reference ripple; cli.options.prior_model_of reads it): its
    physics (model.physics.PhysicsParams: Ra, Ke and the named effects it was trained with), and
    where it came from, for the statement."""

    physics: object
    source: str

    def rpm(self, path, df, meta: dict) -> np.ndarray:
        """n_M2 of every row of one log (its rows df, metadata meta) with the model's effects and the
        observer's lag and thermal rules (train.physics_rpm): the rows as they are, none filtered."""
        from ..logs.dataset import Recording
        from ..model import train
        rows = df if "seq" in df else df.assign(seq=np.arange(len(df), dtype=np.int64))
        rec = Recording(name=str(path), source=pathlib.Path(path), meta=dict(meta), df=rows, removed=[], n_train=0)
        return np.asarray(train.physics_rpm(rec, self.physics), float)

    def to_json(self) -> dict:
        """Where the prior came from, as summary.json and metrics.json / diagnosis.json record it."""
        return {"folder": self.source, "effects": self.physics.effect_names(),
                "ra_ohm": float(self.physics.ra_ohm), "ke_vs_per_rad": float(self.physics.ke_vs_per_rad)}

    def describe(self) -> str:
        effects = self.physics.effect_names()
        return f"model {self.source} (M2 with {', '.join(effects) if effects else 'no effects'})"
