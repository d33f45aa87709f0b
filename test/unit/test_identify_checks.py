"""Self-check of identifications: believable results pass, results from bad data do not."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.identify.checks import (CheckLimits, check_identification,
                                               section_fit_limits)
from pier_monitor.core.identify.equation_error import fit_equation_error
from pier_monitor.core.ingest import ingest_recording
from pier_monitor.core.ingest.window import MeasuredWindow, Reproduced
from pier_monitor.core.model.config import SpringParameters, load_config
from pier_monitor.core.model.solver import simulate
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.shaking_table import edefense_scenario, generate_recording


@pytest.fixture(scope="module")
def windows() -> list[MeasuredWindow]:
    """The two windows of a short synthetic shaking-table test (run 2 yields sections 1-2)."""
    config = load_config(find_config_file("edefense_like.yaml"))
    scenario = edefense_scenario(record_s=20.0, lead_s=12.0, gap_s=18.0, tail_s=18.0)
    windows, _ = ingest_recording(generate_recording(config, scenario, seed=0).recording)
    assert len(windows) == 2
    return windows


def identified(window: MeasuredWindow) -> tuple[SpringParameters, Reproduced]:
    """A real identification: the equation-error fit, and the responses it reproduces."""
    fit = fit_equation_error(window.geometry, window.x, window.v, window.a, window.ag,
                             window.design)
    r = simulate(window.geometry, fit.params, window.ag, window.dt)
    n = window.t.size  # the solver may stop one sample short of the window's end
    full = {k: np.pad(getattr(r, k), ((0, n - getattr(r, k).shape[0]), (0, 0)), mode="edge")
            for k in ("a", "v", "x", "theta", "moment")}
    return fit.params, Reproduced(t=window.t, **full)


@pytest.mark.parametrize("run", [0, 1])
def test_identification_of_clean_data_has_no_reasons(windows, run):
    params, reproduced = identified(windows[run])
    assert check_identification(params, reproduced, windows[run]) == []


def test_an_unrepaired_wire_glitch_makes_the_identification_unreliable(windows):
    w = windows[0]
    x, v = np.array(w.x), np.array(w.v)
    k = w.t.size // 3
    x[k, 2] += 0.5  # +500 mm on one sample of level 3, and what the fusion makes of it
    v[k - 1, 2] += 0.5 / w.dt
    v[k, 2] -= 0.5 / w.dt
    bad = dataclasses.replace(w, x=x, v=v)
    params, reproduced = identified(bad)
    reasons = check_identification(params, reproduced, bad)
    assert any(r.startswith("section 3: c = ") and "is near zero" in r for r in reasons), reasons
    assert any(r.startswith("level 3: the reproduced displacement departs") for r in reasons)


def test_a_displacement_gain_error_makes_the_identification_unreliable(windows):
    w = windows[1]
    x = np.array(w.x)
    x[:, 1] *= 1.5
    bad = dataclasses.replace(w, x=x)
    params, reproduced = identified(bad)
    reasons = check_identification(params, reproduced, bad)
    assert any(r.startswith("level 2: the reproduced displacement departs") for r in reasons)


def test_a_reversed_acceleration_makes_the_identification_unreliable(windows):
    w = windows[0]
    a = np.array(w.a)
    a[:, 0] *= -1.0
    bad = dataclasses.replace(w, a=a)
    params, reproduced = identified(bad)
    reasons = check_identification(params, reproduced, bad)
    assert [r for r in reasons if r.startswith("level 1: the reproduced acceleration")], reasons


def test_parameters_at_bounds_or_implausible_are_named(windows):
    w = windows[0]
    params, reproduced = identified(w)
    d = w.design
    odd = SpringParameters(k1=d.k1 * np.array([1e-3, 1.0, 50.0, 1.0]),
                           k2=d.k1 * np.array([1e-4, 0.5, 0.1, 0.1]),
                           fy=d.fy * np.array([1.0, 1.0, 1.0, 1e-3]),
                           c=d.c * np.array([1.0, 1e-16, 1.0, 1e3]))
    reasons = check_identification(odd, reproduced, w)
    text = "\n".join(reasons)
    assert "section 1: k1 = " in text and "is near zero (0.001 of the design" in text
    assert "section 2: k2 = " in text and "sits at its bound 0.5 k1" in text
    assert "section 2: c = 1.2e-09 N·m·s/rad is near zero" in text
    assert "section 3: k1 = " in text and "is 50 times the design" in text
    assert "section 4: c = " in text and "is 1e+03 times the reference" in text
    assert "section 4: ductility factor" in text and "is implausible (above 20)" in text
    assert check_identification(odd, reproduced, w, CheckLimits(
        k1_ratio=(1e-4, 100.0), c_ratio=(1e-20, 1e4), k2_cap=1.0, max_df=1e9)) == []


def test_the_ductility_judged_is_the_one_the_result_reports(windows):
    """Given the reported DFs (a Takeda event's, on its own skeleton), the check judges
    those, not the bilinear ratio of the parameters: section 4's fy at 1e-3 of the design
    is no reason then, a reported DF of 25 at section 2 is."""
    w = windows[0]
    params, reproduced = identified(w)
    odd = dataclasses.replace(params, fy=params.fy * np.array([1.0, 1.0, 1.0, 1e-3]))
    assert any("section 4: ductility factor" in r for r in check_identification(
        odd, reproduced, w))
    assert not any("ductility factor" in r for r in check_identification(
        odd, reproduced, w, ductility=np.array([3.0, 1.4, 1.0, 0.6])))
    reasons = check_identification(odd, reproduced, w, ductility=np.array([3.0, 25.0, 1.0,
                                                                              0.6]))
    assert [r for r in reasons if "ductility factor" in r] == [
        "section 2: ductility factor 25 is implausible (above 20)"]
    with pytest.raises(InputDataError, match="ductility: expected 4 values"):
        check_identification(params, reproduced, w, ductility=np.ones(3))


def test_a_damper_or_k2_at_its_limit_is_its_sections_own(windows):
    """A ``c`` out of range or a ``k2`` at its cap is returned per section, and with
    ``sections_apart`` left out of the whole event's reasons; ``k1`` and DF stay there,
    but where every section was fitted on its own (``k1_too``, ``k1_apart``) ``k1`` is its
    section's too."""
    w = windows[0]
    params, reproduced = identified(w)
    d = w.design
    odd = SpringParameters(k1=d.k1 * np.array([1e-3, 1.0, 1.0, 1.0]), k2=d.k1 * np.array(
        [1e-4, 0.5, 0.1, 0.1]), fy=d.fy, c=d.c * np.array([1.0, 1e-16, 1.0, 1e3]))
    local = section_fit_limits(odd, w)
    assert [[q for q, _ in r] for r in local] == [[], ["k2", "c"], [], ["c"]]
    assert local[1][0][1].startswith("section 2: k2 = ")
    assert "sits at its bound 0.5 k1" in local[1][0][1]
    assert local[1][1][1].startswith("section 2: c = 1.2e-09 N·m·s/rad is near zero")
    assert local[3][0][1].startswith("section 4: c = ")
    assert "is 1e+03 times the reference" in local[3][0][1]
    whole = check_identification(odd, reproduced, w, sections_apart=True)
    assert [r.split(":")[0] for r in whole] == ["section 1"]
    assert "k1 = " in whole[0] and "is near zero (0.001 of the design" in whole[0]
    everything = check_identification(odd, reproduced, w)
    assert set(everything) == set(whole) | {r for sec in local for _, r in sec}
    assert section_fit_limits(params, w) == [[], [], [], []]
    # every section fitted on its own (the equation-error route): k1 is its section's too
    own = section_fit_limits(odd, w, k1_too=True)
    assert [[q for q, _ in r] for r in own] == [["k1"], ["k2", "c"], [], ["c"]]
    assert own[0][0][1] == whole[0]
    assert check_identification(odd, reproduced, w, sections_apart=True, k1_apart=True) == []
    assert check_identification(odd, reproduced, w, k1_apart=True) == everything


def test_mismatched_shapes_are_an_input_data_error(windows):
    w = windows[0]
    params, reproduced = identified(w)
    short = dataclasses.replace(reproduced, x=reproduced.x[:-1])
    with pytest.raises(InputDataError, match=r"reproduced x: expected shape \(\d+, 4\)"):
        check_identification(params, short, w)
