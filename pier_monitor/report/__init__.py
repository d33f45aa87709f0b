"""Reports of identifications: result files, damage-state mcap, figures, comparisons, and
the results store (:class:`~pier_monitor.report.store.ResultsStore`).

Imports core, bags and Matplotlib (Agg canvas, no pyplot); never torch or rclpy, so that it
can run wherever results are read.  Figures take an identification run by its attributes
(:class:`~pier_monitor.report.figures.RunLike`).
"""

from __future__ import annotations

from pier_monitor.core.errors import ReportError

from .compare import (COMPARE_JSON, COMPARE_PNG, Comparison, ComparisonPaths, SectionChange,
                      compare_results, write_comparison)
from .figures import (FIGURE_DPI, PROFILE_FIGSIZE_IN, RunLike, plot_hysteresis, plot_profile,
                      plot_responses, plot_training)
from .results import (DAMAGE_STATE_TYPE, RESULT_JSON, ResultsPaths, WrittenResult,
                      damage_state_fields, damage_state_message, damage_state_topic, load_result,
                      prepare_result, write_damage_state_mcap, write_results)
from .store import ResultsStore
from .tables import uncertainty_table

__all__ = [
    "COMPARE_JSON",
    "COMPARE_PNG",
    "Comparison",
    "ComparisonPaths",
    "DAMAGE_STATE_TYPE",
    "FIGURE_DPI",
    "PROFILE_FIGSIZE_IN",
    "RESULT_JSON",
    "ReportError",
    "ResultsPaths",
    "ResultsStore",
    "RunLike",
    "SectionChange",
    "WrittenResult",
    "compare_results",
    "damage_state_fields",
    "damage_state_message",
    "damage_state_topic",
    "load_result",
    "plot_hysteresis",
    "plot_profile",
    "plot_responses",
    "plot_training",
    "prepare_result",
    "uncertainty_table",
    "write_comparison",
    "write_damage_state_mcap",
    "write_results",
]
