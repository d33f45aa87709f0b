"""Field-network test cases: two piers, two shakings, three sensor layouts (SPEC §6).

The field benchmark identifies each pier from the sensors a monitoring network would have
(:mod:`~pier_monitor.core.synthetic.layouts`), recorded by imperfect sensors
(:class:`~pier_monitor.core.synthetic.measurement.SensorImperfections`) through an
anti-aliasing data logger, under one of two earthquakes:

``strong``
    yields the lower sections clearly (DF well above 1.5) and leaves the upper ones elastic;
``just_yield``
    only just yields the most loaded section (DF between 1.2 and 1.5: "suspicious").

The piers are the E-Defense-like pier (``config/edefense_like.yaml``, as built: the true
parameters of run 1 of :func:`~pier_monitor.core.synthetic.shaking_table.edefense_scenario`)
and the paper's Table 1 pier with a monitoring sensor map (``config/table1_field.yaml``, the
true parameters are the file's).  The table records are fixed (like a laboratory replaying its
chosen waves), so that the damage is the documented one whatever the seed, which then varies
the ambient motion, the noise and the sensor errors.  With the default stretches the true
ductility factors, sections bottom to top, are about:

=========  ===========  ==========================================
pier       shaking      ductility factors
=========  ===========  ==========================================
edefense   strong       3.19, 1.76, 0.97, 0.64
edefense   just_yield   1.35, 0.95, 0.85, 0.57
table1     strong       3.19, 2.23, 0.85, 0.64, 0.42, 0.21
table1     just_yield   1.35, 0.98, 0.71, 0.53, 0.35, 0.18
=========  ===========  ==========================================

(table1 at the 200 Hz of ``table1_field.yaml``: the records are drawn at the pier's rate.)

With ``hysteresis="takeda"`` or ``"bwbn"`` the pier is the RC test-bed of :mod:`~pier_monitor.core.synthetic.rc`
(cracking, stiffness degradation, pinching, strength loss, Rayleigh damping): the same records
scaled to each pier's ``rc_pga_mps2``; that module's docstring gives its truth (idealised DF,
bar yield, small-amplitude stiffness before and after).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Mapping

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.model.config import PierConfig, load_config
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.layouts import layout_config
from pier_monitor.core.synthetic.measurement import SensorImperfections
from pier_monitor.core.synthetic.rc import HYSTERESIS_FAMILIES
from pier_monitor.core.synthetic.shaking_table import (DEFAULT_START_NS, RunSpec, Scenario,
                                                       SyntheticRecording, edefense_scenario,
                                                       generate_recording)

__all__ = ["FieldPier", "FIELD_PIERS", "SHAKINGS", "SCENARIO_NAMES", "field_pier",
           "field_scenario", "named_scenario", "field_recording", "field_case_recording"]

#: Shakings of :func:`field_scenario`.
SHAKINGS = ("strong", "just_yield")
#: Scenarios by name (:func:`named_scenario`): the two-run shaking-table test and the shakings.
SCENARIO_NAMES = ("edefense", *SHAKINGS)
_RECORD_S = 40.0  # the documented ductility factors hold for this record length


@dataclass(frozen=True)
class FieldPier:
    """A pier of the field benchmark.

    Attributes
    ----------
    name : str
        Short name (``edefense``, ``table1``).
    pier_id : str
        ``pier_id`` of its configuration.
    config_file : str
        Configuration shipped with the package (full sensor map).
    runs : dict of str to RunSpec
        The run of each shaking.
    rc_pga_mps2 : dict of str to dict of str to float
        Table PGA of each shaking on the RC test-bed, by spring family then shaking, m/s².
    """

    name: str
    pier_id: str
    config_file: str
    runs: Mapping[str, RunSpec]
    rc_pga_mps2: Mapping[str, Mapping[str, float]]


_EDEFENSE_AS_BUILT = dict(k1_factors=(1.0, 0.95, 1.05, 0.8), fy_factors=(1.05, 1.0, 1.0, 1.0))

#: The piers of the field benchmark, by short name.
FIELD_PIERS = {
    "edefense": FieldPier("edefense", "edefense_pier", "edefense_like.yaml", {
        "strong": RunSpec("strong", pga_mps2=4.0, duration_s=_RECORD_S, motion_seed=2024,
                          **_EDEFENSE_AS_BUILT),
        "just_yield": RunSpec("just_yield", pga_mps2=3.5, duration_s=_RECORD_S, motion_seed=7,
                              **_EDEFENSE_AS_BUILT),
    }, {"takeda": {"strong": 3.8, "just_yield": 3.0},
        "bwbn": {"strong": 6.5, "just_yield": 4.3}}),
    "table1": FieldPier("table1", "table1", "table1_field.yaml", {
        "strong": RunSpec("strong", pga_mps2=3.0, duration_s=_RECORD_S, motion_seed=7),
        "just_yield": RunSpec("just_yield", pga_mps2=1.15, duration_s=_RECORD_S,
                              motion_seed=1994),
    }, {"takeda": {"strong": 3.0, "just_yield": 1.15},
        "bwbn": {"strong": 3.0, "just_yield": 1.08}}),
}


def field_pier(pier: str) -> FieldPier:
    """The field pier with this short name or ``pier_id``.

    Raises
    ------
    InputDataError
        If it is neither; the message lists the piers there are.
    """
    for p in FIELD_PIERS.values():
        if pier in (p.name, p.pier_id):
            return p
    raise InputDataError(f"no field scenario for pier {pier!r}; the field piers are "
                         + ", ".join(f"{p.name} ({p.pier_id})" for p in FIELD_PIERS.values()))


def field_scenario(pier: str = "edefense", shaking: str = "strong", *, lead_s: float = 20.0,
                   tail_s: float = 20.0, start_ns: int = DEFAULT_START_NS,
                   hysteresis: str = "bilinear") -> Scenario:
    """A one-run earthquake on a field pier (see the module docstring for the damage).

    Parameters
    ----------
    pier : str
        ``edefense`` or ``table1`` (or their ``pier_id``).
    shaking : {"strong", "just_yield"}
        Which earthquake.
    lead_s, tail_s : float
        Quiet (ambient) recording before and after the 40 s record, s.
    start_ns : int
        Time of the first sample, ns since the Unix epoch.
    hysteresis : str
        ``bilinear``, or an RC family: then the record is scaled to the pier's
        ``rc_pga_mps2`` of that family (the RC test-bed's damage,
        :mod:`~pier_monitor.core.synthetic.rc`).

    Raises
    ------
    InputDataError
        If the pier, the shaking or the hysteresis is unknown.
    """
    if shaking not in SHAKINGS:
        raise InputDataError(f"shaking: expected one of {list(SHAKINGS)}, got {shaking!r}")
    if hysteresis not in HYSTERESIS_FAMILIES:
        raise InputDataError(f"hysteresis: expected one of {list(HYSTERESIS_FAMILIES)}, got "
                             f"{hysteresis!r}")
    spec = field_pier(pier)
    run = spec.runs[shaking]
    if hysteresis != "bilinear":
        run = replace(run, pga_mps2=spec.rc_pga_mps2[hysteresis][shaking])
    return Scenario(runs=(run,), lead_s=lead_s, tail_s=tail_s, start_ns=start_ns)


def named_scenario(name: str, pier_id: str, hysteresis: str = "bilinear") -> Scenario:
    """A scenario by name: ``edefense`` (the two-run shaking-table test of the E-Defense-like
    pier, :func:`~pier_monitor.core.synthetic.shaking_table.edefense_scenario`), or a shaking
    of :func:`field_scenario` for the field pier ``pier_id``.

    ``hysteresis`` picks the amplitudes of the RC test-bed for an RC family.

    Raises
    ------
    InputDataError
        If the name is unknown, or the pier has no field scenario.
    """
    if name == "edefense":
        return edefense_scenario(hysteresis=hysteresis)
    if name not in SHAKINGS:
        raise InputDataError(f"scenario: expected one of {list(SCENARIO_NAMES)}, got {name!r}")
    return field_scenario(pier_id, name, hysteresis=hysteresis)


def field_recording(config: PierConfig, layout: str, scenario: Scenario, *, gnss: bool = False,
                    seed: int = 0,
                    imperfections: SensorImperfections | None = SensorImperfections(),
                    intermediate_levels: tuple[int, ...] | None = None,
                    hysteresis: str = "bilinear",
                    principal_response=None) -> SyntheticRecording:
    """Record a scenario with a field layout of a pier's sensor map, as a field network would.

    The layout's configuration (:func:`~pier_monitor.core.synthetic.layouts.layout_config`)
    is the one the recording carries; the sensors that record it are imperfect
    (``imperfections``, default 1 % gain, 0.5° azimuth, tilt and bias) and every one low-passes
    its signal before sampling it (anti-aliasing).

    Parameters
    ----------
    config : PierConfig
        The pier with its full sensor map.
    layout : {"full", "accel", "sparse"}
        Sensors kept.
    scenario : Scenario
        What is played (e.g. :func:`field_scenario`).
    gnss : bool
        Add the GNSS receiver at the top.
    seed : int
        Seed of the ambient motion, the noise and the sensor errors.
    imperfections : SensorImperfections or None
        Spread of the sensor errors; ``None``: ideal sensors.
    intermediate_levels : tuple of int, optional
        Intermediate levels of the ``sparse`` layout (default: nearest mid-height).
    hysteresis : {"bilinear", "takeda", "bwbn"}
        Springs of the simulated pier (:func:`~pier_monitor.core.synthetic.shaking_table.
        generate_recording`).
    principal_response : callable, optional
        A structural model of its own for the principal response (e.g. the fiber column of
        :mod:`~pier_monitor.core.synthetic.fiber`), passed to ``generate_recording``.
    """
    field = layout_config(config, layout, gnss, intermediate_levels)
    return generate_recording(field, scenario, seed=seed, imperfections=imperfections,
                              anti_alias=True, hysteresis=hysteresis,
                              principal_response=principal_response)


def field_case_recording(pier: str, layout: str, gnss: bool = False, shaking: str = "strong",
                         seed: int = 0, *, imperfections: SensorImperfections | bool = True,
                         hysteresis: str = "bilinear") -> SyntheticRecording:
    """One case of the field benchmark, in memory: the recording and its ground truth.

    Parameters
    ----------
    pier : {"edefense", "table1"}
        The pier (its shipped configuration, full sensor map).
    layout : {"full", "accel", "sparse"}
        Sensors kept.
    gnss : bool
        Add the GNSS receiver at the top (10 Hz, 5 mm).
    shaking : {"strong", "just_yield"}
        The earthquake (:func:`field_scenario`).
    seed : int
        Noise seed: ambient motion, sensor noise and sensor errors.
    imperfections : SensorImperfections or bool
        The sensors' errors: ``True`` the default :class:`SensorImperfections`, ``False``
        ideal sensors, or a :class:`SensorImperfections` of their own (e.g. no tilt or bias).
    hysteresis : {"bilinear", "takeda", "bwbn"}
        ``bilinear``: the identifier's own springs; ``takeda``, ``bwbn``: the RC test-bed,
        with its amplitudes (``rc_pga_mps2``) and truth.

    Returns
    -------
    SyntheticRecording
        ``recording.config`` is the field configuration (nominal sensors);
        ``truth.sensor_errors`` the sensors' true errors.
    """
    spec = field_pier(pier)
    config = load_config(find_config_file(spec.config_file))
    if isinstance(imperfections, bool):
        imperfections = SensorImperfections() if imperfections else None
    return field_recording(config, layout,
                           field_scenario(spec.name, shaking, hysteresis=hysteresis), gnss=gnss,
                           seed=seed, imperfections=imperfections, hysteresis=hysteresis)
