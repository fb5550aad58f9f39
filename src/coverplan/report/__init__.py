"""Pictures of a plan: a self-contained HTML flight report and PNG figures."""

from coverplan.report.figures import write_figures
from coverplan.report.html import write_html_report

__all__ = ["write_html_report", "write_figures"]
