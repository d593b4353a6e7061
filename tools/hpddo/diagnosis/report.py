"""The diagnosis report (index.html and diagnosis.json): see hpddo.reports.diagnosis,
which renders it from the report templates (hpddo/reports/templates)."""
from __future__ import annotations

from ..reports.diagnosis import fig_corr, fig_overlays, fig_where, figures, page, summary, write  # noqa: F401
