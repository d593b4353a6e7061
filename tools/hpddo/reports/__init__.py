"""The HTML reports of hpddo, from one place: Jinja2 templates (templates/*.html.j2, with
autoescape on, so every text from a log or a result is escaped), one stylesheet
(style.css, embedded into every page) and one figure helper (`png`: a matplotlib figure
as an embedded PNG data URI, the figure closed after use). Every page is self-contained.

    reports.training.write(...)   the training report (hpddo train, demo)
    reports.diagnosis.write(...)  the diagnosis report (hpddo diagnose)

The submodules are imported on use, so importing this package does not load the
diagnosis. `browser` opens a page in headless Chromium, as a person would (the tests).
`live` is the one page that is not a file: hpddo live's Bokeh server application, which
draws the bench's rows as they arrive.

May import: the foundations, hpddo.logs, hpddo.model, hpddo.ripple, hpddo.evaluation and hpddo.diagnosis
(the diagnosis page shows its stages).
"""
from __future__ import annotations

import base64
import functools
import io
import pathlib

import jinja2
import markupsafe

HERE = pathlib.Path(__file__).resolve().parent
TEMPLATES = HERE / "templates"
STYLE = HERE / "style.css"
DPI = 90


def png(fig, dpi: int = DPI, crop: bool = True) -> str:
    """The figure as a data:image/png;base64 URI (tight bounding box: crop); closes the figure,
    also when saving it fails. crop=False for a figure laid out already (fig.tight_layout): the
    tight box costs a second draw of the whole figure (0.1-0.2 CPU-s a figure of the diagnosis'
    report on the 13.6k-row bench, item 8's)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    try:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight" if crop else None)
    finally:
        plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


@functools.lru_cache(maxsize=None)
def css() -> str:
    """The one stylesheet of every report page."""
    return STYLE.read_text(encoding="utf-8")


@functools.lru_cache(maxsize=None)
def environment() -> jinja2.Environment:
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(TEMPLATES)), autoescape=True,
                             undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
                             keep_trailing_newline=True)
    env.filters["dash"] = dash
    return env


def dash(x, nd: int = 2) -> str:
    """x with nd decimals; "–" for a missing or non-finite value."""
    import math

    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return f"{x:.{nd}f}"


def render(template: str, **context) -> str:
    """The page `template` (a name in templates/) rendered with context; the stylesheet is
    passed as `css`."""
    return environment().get_template(template).render(css=markupsafe.Markup(css()), **context)
