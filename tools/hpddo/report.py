"""HTML report of a pipeline run (hpddo train, hpddo demo): see hpddo.reports.training,
which renders it from the report templates (hpddo/reports/templates)."""
from __future__ import annotations

from .reports import png  # noqa: F401
from .reports.training import COLOURS, MODELS, overlay_figure, page, rmse_rows, write  # noqa: F401
