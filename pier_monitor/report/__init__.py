"""Reports of identifications: result files, damage-state mcap, figures, comparisons.  The
results store they are kept in is :class:`~pier_monitor.store.ResultsStore`, outside this
package: a report only renders.

Imports core, bags and Matplotlib (Agg canvas, no pyplot); never torch or rclpy, so that it
can run wherever results are read.  Figures take an identification run by its attributes
(:class:`~pier_monitor.report.figures.RunLike`).
"""

from __future__ import annotations

from pier_monitor.core.lazy import lazy_names

from pier_monitor.core.errors import ReportError


#: Where each public name lives: loaded on first use (PEP 562), so that importing one
#: submodule does not load the others' heavy dependencies.
_LAZY = {
    "COMPARE_JSON": "compare",
    "COMPARE_PNG": "compare",
    "Comparison": "compare",
    "ComparisonPaths": "compare",
    "DAMAGE_STATE_TYPE": "results",
    "FIGURE_DPI": "figures",
    "PROFILE_FIGSIZE_IN": "figures",
    "RESULT_JSON": "results",
    "ResultsPaths": "results",
    "RunLike": "figures",
    "SectionChange": "compare",
    "WrittenResult": "results",
    "compare_results": "compare",
    "damage_state_fields": "results",
    "damage_state_message": "results",
    "damage_state_topic": "results",
    "load_result": "results",
    "plot_hysteresis": "figures",
    "plot_profile": "figures",
    "plot_responses": "figures",
    "plot_training": "figures",
    "prepare_result": "results",
    "uncertainty_table": "tables",
    "write_comparison": "compare",
    "write_damage_state_mcap": "results",
    "write_results": "results",
}


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

__getattr__, __dir__ = lazy_names(__name__, _LAZY, __all__)
