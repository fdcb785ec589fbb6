"""feedscope: sensorless friction of CNC ball-screw feed drives, from controller traces.

The Python face of the feedscope library (Rust). Every function calls the same library code as
the ``feedscope`` binary's subcommand of the same name, with the same defaults, so numbers agree
with the binary's to the last printed digit. Units are in the names: ``position_mm``,
``time_s``, ``velocity_mm_s``, ``friction_n``, ``feed_mm_min``.

>>> import feedscope
>>> sim = feedscope.simulate()                        # the digital twin, known friction
>>> result = feedscope.estimate(sim.trace, sim.axis)  # paper 000, Eq. 5
>>> s = result.strokes[0]; s.position_mm, s.friction_n  # numpy arrays (mm, N)

Errors are ``FeedscopeError`` subclasses, one per kind of the library's errors:
``BadInputError`` (the binary's exit code 2: the message names the file, line or key),
``IoError`` and ``InternalError`` (exit code 1). Wrong Python types and numpy dtypes or shapes
raise ``TypeError``; unknown option words raise ``ValueError``.
"""

from ._feedscope import (
    MapResult,
    map,
    History,
    HistoryEntry,
    TrendResult,
    DynamicsResult,
    dynamics,
    IdentifyResult,
    identify,
    StribeckResult,
    fit_stribeck,
    Plan,
    plan_strokes,
    plan_triangle,
    AnalyzeResult,
    StrokeProfile,
    analyze,
    Axis,
    BadInputError,
    EstimateResult,
    FeedscopeError,
    InternalError,
    IoError,
    Simulation,
    Stroke,
    Trace,
    __version__,
    default_sim_config,
    estimate,
    read_trace,
    simulate,
)

__all__ = [
    "MapResult",
    "map",
    "History",
    "HistoryEntry",
    "TrendResult",
    "DynamicsResult",
    "dynamics",
    "IdentifyResult",
    "identify",
    "StribeckResult",
    "fit_stribeck",
    "Plan",
    "plan",
    "plan_strokes",
    "plan_triangle",
    "AnalyzeResult",
    "StrokeProfile",
    "analyze",
    "Axis",
    "BadInputError",
    "EstimateResult",
    "FeedscopeError",
    "InternalError",
    "IoError",
    "Simulation",
    "Stroke",
    "Trace",
    "__version__",
    "default_sim_config",
    "estimate",
    "read_trace",
    "simulate",
]


def plan(test, **kwargs):
    """The NC program of a friction test, as ``feedscope plan strokes|triangle``:
    ``plan("strokes", from_mm=..., to_mm=..., feeds_mm_min=[...], ...)`` is
    ``plan_strokes(...)``, ``plan("triangle", ...)`` is ``plan_triangle(...)``."""
    if test == "strokes":
        return plan_strokes(**kwargs)
    if test == "triangle":
        return plan_triangle(**kwargs)
    raise ValueError(f'test must be "strokes" or "triangle", not {test!r}')
