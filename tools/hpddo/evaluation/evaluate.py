"""Validation of a trained model on recordings it never saw (hpddo evaluate).

Every row of every recording is scored: the recordings are cleaned as for training (the
glitch filter, unless switched off), replayed through the board observer compiled
against the model's header (the native replay, split 0: no training part), and scored
against the encoder with the same table as training (M1, M2, M3 and the model's lookup
baseline, lookup.json).
"""
from __future__ import annotations

import dataclasses
import json
import pathlib
import re
import tempfile

import numpy as np

from . import baseline, replay
from .. import progress
from ..logs import dataset
from . import metrics as metrics_mod
from ..logs.errors import InputError

REPLAY_SOURCE = "native replay (hpddo_core observer, per-sample)"


def score_recordings(recs, estimates, checksum: int | None, lookup: baseline.Lookup | None = None,
                     part: str = "test") -> dict:
    """The metrics of the replay's estimates of recs (one DataFrame each, every row) and
    of the lookup baseline where given, scored on the rows of `part` ("test": the
    held-out rows; "all": every row)."""
    scored = []
    for r, est in zip(recs, estimates):
        if len(est) != r.n:
            raise RuntimeError(f"replay wrote {len(est)} estimates for {r.n} rows of {r.name}")
        if lookup is not None:
            est = est.assign(rpm_lookup=lookup.predict_rows(r))
        ref = r.df["rpm_ref"].to_numpy(float) if "rpm_ref" in r.df else np.full(r.n, np.nan)
        mask = np.ones(r.n, bool) if part == "all" else np.arange(r.n) >= r.n_train
        scored.append((r.name, ref, est, mask))
    return metrics_mod.score(scored, REPLAY_SOURCE, checksum)


def recordings_record(recs) -> dict:
    """What metrics.json says of the recordings themselves: the rows the glitch filter
    removed (file line and reason), the warnings, the recording names."""
    return {"glitches_removed": {r.name: {"file": r.source.name, "rows_in_file": r.rows_in_file,
                                          "removed": [{"line": ln, "reason": why} for ln, why in r.removed]}
                                 for r in recs},
            "warnings": [w for r in recs for w in r.warnings],
            "recordings": [r.name for r in recs], **reference_record(recs)}


def reference_record(recs) -> dict:
    """{"reference": ...} where rpm_ref came from the ripple (hpddo.ripple.reference): each
    recording's record and the rows kept and left out, by reason, over all; {} for the encoder."""
    from ..ripple import reference
    pooled = reference.pooled({r.name: r.reference for r in recs})
    return {} if pooled is None else {"reference": pooled}


def replay_natively(recs, model_dir: pathlib.Path, name: str, work: pathlib.Path, split: float | None = None) -> list:
    """Writes the cleaned recordings into work/logs, builds the replay for model_<name>.h of
    model_dir into work/replay and replays them into work/estimates; their estimates."""
    (work / "logs").mkdir(parents=True, exist_ok=True)
    (work / "estimates").mkdir(exist_ok=True)
    progress.stage(f"writing the cleaned logs ({sum(r.n for r in recs)} rows)")
    clean = [dataset.write_clean(r, work / "logs" / f"{r.file_stem}.csv") for r in recs]
    progress.stage("building the native replay (CMake, C++)")
    exe = replay.build(pathlib.Path(model_dir), name, work / "replay")
    progress.stage(f"replaying {len(recs)} recording(s) through the board observer")
    return replay.run(exe, clean, work / "estimates", split)


SOURCE = "native replay (hpddo_core observer, per-sample), every row of recordings the model was not trained on"


@dataclasses.dataclass
class Evaluation:
    recordings: list
    metrics: dict
    table: str
    estimates: pathlib.Path  # the replay's estimates files (gone when evaluate() used a temporary folder)


def model_header(model_dir: pathlib.Path, name: str | None = None) -> tuple[str, int]:
    """(model name, checksum) of the model header in model_dir: model_<name>.h, the only
    one there when name is None (fixed-point companions, model_<name>_q.h, not counted)."""
    model_dir = pathlib.Path(model_dir)
    if not model_dir.is_dir():
        raise InputError(f"{model_dir}: no such model folder (an output of hpddo train)")
    headers = sorted(model_dir.glob(f"model_{name}.h" if name else "model_*.h"))
    # The fixed-point companion model_<name>_q.h (export.model_header_q) is the same model
    # for the boards; the replay scores the float one.
    headers = [h for h in headers if not h.read_text(encoding="utf-8", errors="replace").startswith(
        "// GENERATED fixed-point model header")]
    if len(headers) != 1:
        found = ", ".join(h.name for h in headers) or "none"
        raise InputError(f"{model_dir}: expected one model header {'model_' + name + '.h' if name else 'model_*.h'}, "
                         f"found {found}" + ("; choose one with --name" if len(headers) > 1 else ""))
    text = headers[0].read_text(encoding="utf-8", errors="replace")
    m = re.search(r"kChecksum\s*=\s*0x([0-9a-fA-F]{8})u", text)
    if not m:
        raise InputError(f"{headers[0]}: not a model header of hpddo train (no kChecksum)")
    return headers[0].stem[len("model_"):], int(m.group(1), 16)


def model_physics(model_dir: pathlib.Path, name: str | None = None):
    """The identified M2 (model.physics.PhysicsParams: Ra, Ke and the named effects) of the model
    in model_dir (model_header picks its header); an InputError naming the folder or the header
    where it is not a model of hpddo train."""
    from ..model.export import read_model_header
    model_name, _ = model_header(model_dir, name)
    header = pathlib.Path(model_dir) / f"model_{model_name}.h"
    try:
        return read_model_header(header.read_text(encoding="utf-8")).physics
    except (ValueError, AttributeError, KeyError, IndexError, TypeError) as exc:
        raise InputError(f"{header}: not a model header of hpddo train that reads back ({exc})") from None


def evaluate(model_dir, log_paths, work_dir: pathlib.Path | None = None, name: str | None = None,
             glitch_filter: bool = True, reference=None) -> Evaluation:
    """Scores the model in model_dir (its header model_<name>.h and lookup.json) on every
    row of log_paths. work_dir receives the cleaned logs, the replay built for the model
    and its estimates (work_dir/estimates/*.estimates.csv); None: a temporary folder.
    reference: the speed scored against (hpddo.ripple.reference; None: the encoder)."""
    model_name, checksum = model_header(model_dir, name)
    lookup_path = pathlib.Path(model_dir) / baseline.FILE
    lookup = baseline.Lookup.read(lookup_path) if lookup_path.is_file() else None
    recs = dataset.load_recordings(log_paths, 0.0, glitch_filter, reference)
    if work_dir is None:
        with tempfile.TemporaryDirectory(prefix="hpddo-evaluate-") as tmp:
            return _replay_and_score(model_dir, model_name, checksum, lookup, recs, pathlib.Path(tmp))
    return _replay_and_score(model_dir, model_name, checksum, lookup, recs, pathlib.Path(work_dir))


def temperature_warning(physics, rec) -> str | None:
    """The line for a recording without temp_C that a model with thermal effects is scored
    on: the observer then takes the case at the model's ambient on every row (as a board
    without a sensor does), and the thermal terms correct for a temperature that was not
    there. None where that is not the case."""
    from .. import schema
    thermal = [n for n in physics.effect_names() if schema.BY_NAME[n].thermal or schema.BY_NAME[n].case_temperature]
    if not thermal or rec.has_temp():
        return None
    return (f"{rec.source}: no temp_C, and the model's {', '.join(thermal)} read the case temperature: the "
            f"observer takes it at the model's ambient, {physics.t_amb_C:.1f} C, on every row, so where the motor "
            "was warmer or colder this recording's error is larger than the model's; record temp_C (a sensor on "
            "the motor's case), or compare with a model trained without thermal effects")


def _replay_and_score(model_dir, model_name, checksum, lookup, recs, work: pathlib.Path) -> Evaluation:
    physics = model_physics(model_dir, model_name)
    for r in recs:
        w = temperature_warning(physics, r)
        if w:
            r.warnings.append(w)
    est = replay_natively(recs, model_dir, model_name, work, split=0.0)
    progress.stage("scoring the estimates")
    m = score_recordings(recs, est, checksum, lookup, part="all")
    m["source"] = SOURCE
    m["model"] = {"folder": str(model_dir), "name": model_name, "effects": physics.effect_names()}
    m.update(recordings_record(recs))
    return Evaluation(recs, m, metrics_mod.table(m, TABLE_TITLE), work / "estimates")


TABLE_TITLE = "RMSE on every row of recordings the model never saw (RPM)"
