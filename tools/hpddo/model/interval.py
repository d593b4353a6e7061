"""A fitted quantity with its 95 % interval, or the reason the recordings do not determine it
and what would: the record every identification gives (model/dynamics.py here, the
diagnosis' intervals in diagnosis/intervals.py)."""
from __future__ import annotations

import dataclasses

LEVEL = 0.95


@dataclasses.dataclass
class Interval:
    """A quantity's value and its 95 % interval from the data (SI); determined: whether
    the recordings determine it; why: the reason when not; needs: what would."""

    quantity: str
    field: str
    unit: str
    value: float
    lo: float | None
    hi: float | None
    determined: bool
    why: str = ""
    needs: str = ""
    clusters: int = 0
    method: str = ""
    show_scale: float = 1.0
    show_unit: str = ""
    # the uncertainty budget (GUM): the standard uncertainty of each part, SI, and what the interval
    # is conditional on ("" where nothing); lo and hi are the value -+ the expanded combination
    budget: dict = dataclasses.field(default_factory=dict)
    given: str = ""
    half_without_ra: float | None = None  # the expanded half-width without the held Ra's doubt
    # the expanded half-width without the spread of the candidate models (intervals.spread_u)
    half_without_models: float | None = None
    # the range physical for it (lo, hi), SI, where it depends on the fit (the winding node's, by heat path)
    physical: tuple | None = None

    def to_json(self) -> dict:
        return {"quantity": self.quantity, "field": self.field, "unit": self.unit, "value": self.value,
                "lo": self.lo, "hi": self.hi, "level": LEVEL, "determined": bool(self.determined),
                "why": self.why, "needs": self.needs, "clusters": self.clusters, "method": self.method,
                "budget": dict(self.budget), "given": self.given, "text": self.text()}

    def text(self) -> str:
        """The quantity in words: its value with the interval, or that it is not determined."""
        s, u = self.show_scale, self.show_unit or self.unit
        if not self.determined:
            return (f"{self.quantity} not determined by these recordings ({self.why}); "
                    f"what would determine it: {self.needs}")
        text = (f"{self.quantity} = {self.value * s:.4g} {u} "
                f"({100 * LEVEL:.0f} % interval {self.lo * s:.4g}..{self.hi * s:.4g} {u}")
        parts = [f"{k} {v * s:.2g}" for k, v in self.budget.items() if k != "expanded" and v > 0]
        if parts:
            text += "; standard uncertainties: " + ", ".join(parts) + f" {u}"
        if self.given:
            text += f"; given {self.given}"
        return text + ")"
