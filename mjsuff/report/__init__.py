"""Reports on finished runs: the paper's figures, its tests between rules, a markdown summary."""

from mjsuff.report.markdown import write_report
from mjsuff.report.results import ReportCell, ReportError, load_cells
from mjsuff.report.statistics import RuleComparison, compare_rules, observations

__all__ = [
    "ReportCell",
    "ReportError",
    "RuleComparison",
    "compare_rules",
    "load_cells",
    "observations",
    "write_report",
]
