"""Reports on finished runs: the paper's figures, its tests between rules, a markdown summary,
and one rule's F1 in two runs compared replicate by replicate."""

from mjsuff.report.markdown import write_report
from mjsuff.report.paired import PairedF1, paired_f1
from mjsuff.report.results import ReportCell, ReportError, load_cells
from mjsuff.report.statistics import RuleComparison, compare_rules, observations

__all__ = [
    "PairedF1",
    "ReportCell",
    "ReportError",
    "RuleComparison",
    "compare_rules",
    "load_cells",
    "observations",
    "paired_f1",
    "write_report",
]
