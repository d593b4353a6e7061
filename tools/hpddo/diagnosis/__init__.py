"""Diagnosis of the physics model against labelled recordings: where it fails, which
physical effect is missing, and the error before and after adding it (docs/diagnosis.md).

May import: the foundations, hpddo.logs, hpddo.model, hpddo.ripple and hpddo.evaluation."""
from .core import Diagnosis, Options, diagnose  # noqa: F401
