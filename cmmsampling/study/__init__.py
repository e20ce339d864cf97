"""The comparison of strategies on one face (compare(), the paper's study) and its report: the
room's modules are compare (the runs and their statistics), figures (matplotlib, PNG) and html
(report.html).
"""
from .compare import DEFAULT_NS, DEFAULT_SEEDS, MEASURES, Study, compare, study_time
from .figures import FIGURES
from .html import write_report

__all__ = ["DEFAULT_NS", "DEFAULT_SEEDS", "FIGURES", "MEASURES", "Study", "compare", "study_time",
           "write_report"]
