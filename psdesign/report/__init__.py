"""HTML report of a study (one self-contained file) and reference permeability models."""

from psdesign.report.html import (
    ReportAlert,
    ReportError,
    build_html,
    write_report,
    write_report_alerts,
)
from psdesign.report.references import (
    KOZENY_CONSTANT,
    TS_ALPHA_IN_PLANE,
    TS_ALPHA_THROUGH_PLANE,
    TS_EPS_P,
    kozeny_carman,
    tomadakis_sotirchos,
)

__all__ = [
    "KOZENY_CONSTANT",
    "TS_ALPHA_IN_PLANE",
    "TS_ALPHA_THROUGH_PLANE",
    "TS_EPS_P",
    "ReportAlert",
    "ReportError",
    "build_html",
    "kozeny_carman",
    "tomadakis_sotirchos",
    "write_report",
    "write_report_alerts",
]
