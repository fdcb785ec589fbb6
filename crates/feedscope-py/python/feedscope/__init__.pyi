"""Type stubs of feedscope (the native module feedscope._feedscope, re-exported).

Units are in the names: ``_s`` seconds, ``_mm`` millimetres, ``_mm_s`` mm/s, ``_mm_s2`` mm/s²,
``_mm_min`` mm/min, ``_n`` newtons, ``_a`` amperes, ``_nm`` newton-metres, ``_hz`` hertz.
Orders are cycles per screw revolution = cycles per lead of table travel. Friction is signed
as paper 000 Eq. 5: positive moving forward (increasing position), negative backward.
"""

import os
from typing import Any, Dict, List, Optional, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Path = Union[str, "os.PathLike[str]"]
_F64 = npt.NDArray[np.float64]

class FeedscopeError(Exception):
    """Base class of every error feedscope raises for its own reasons."""

class BadInputError(FeedscopeError):
    """What was given is wrong; the message names the file, line or key (the binary's exit
    code 2)."""

class IoError(FeedscopeError):
    """A file exists but could not be read or written (the binary's exit code 1). Not an
    OSError."""

class InternalError(FeedscopeError):
    """A failure the input does not explain (the binary's exit code 1)."""

class Axis:
    """A feed axis: the keys of the axis file (TOML/JSON) as keyword arguments.

    Required: ``lead_mm`` (screw lead, mm), ``table_mass_kg`` (moving mass, kg),
    ``inertia_kgm2`` (motor + coupling + screw on the motor shaft, kg·m²),
    ``damping_nms_per_rad`` (viscous damping on the motor shaft, N·m·s/rad),
    ``torque_constant_nm_per_a`` (k_e, N·m/A; unused for torque traces). Optional geometry:
    ``screw_diameter_mm``, ``screw_ball_diameter_mm``, ``contact_angle_deg``,
    ``screw_balls_per_turn``, ``guide_ball_diameter_mm``, ``guide_balls_per_raceway``,
    ``travel_min_mm``, ``travel_max_mm``, ``rapid_rate_mm_min``, ``declared_order`` (list of
    ``{"order": float, "cause": str}``), ``thresholds``, ``name``. Any key reads as an
    attribute. Unknown keys and out-of-range values raise BadInputError naming the key.
    """

    def __init__(self, **keys: Any) -> None: ...
    @staticmethod
    def load(path: _Path, *, for_identification: bool = False) -> "Axis":
        """Read an axis file (TOML, or JSON with a .json extension); for_identification lets
        inertia_kgm2 and damping_nms_per_rad be absent (identify finds them)."""
    @staticmethod
    def for_identification(**keys: Any) -> "Axis":
        """Axis(**keys) without inertia_kgm2/damping_nms_per_rad, for identify()."""
    @property
    def lead_mm(self) -> float:
        """Screw lead (mm)."""
    @property
    def name(self) -> Optional[str]: ...
    def to_dict(self) -> Dict[str, Any]:
        """The file's keys and values (defaults filled in)."""
    def to_toml(self) -> str:
        """The axis as TOML text (the binary's axis.toml)."""
    def __getattr__(self, key: str) -> Any: ...

class Trace:
    """A trace of one axis: position and effort, each channel with its own time stamps.

    From 1-D float64 numpy arrays: ``time_s`` (s) for both channels, or ``position_time_s``
    and ``effort_time_s`` (s) for channels with their own clocks; ``position_mm`` (mm); one of
    ``current_a`` (A) or ``torque_nm`` (N·m). Wrong type, dtype or shape: TypeError; unequal
    lengths, NaN or infinity, times not strictly increasing, fewer than 4 samples, no motion,
    a position jump that does not come back: BadInputError. Isolated position glitches
    (beyond 200 m/min and back) are dropped and listed in ``dropped_position``/``warnings``.
    The arrays are copied once (positions converted to metres inside).
    """

    def __init__(
        self,
        *,
        time_s: Optional[_F64] = None,
        position_mm: Optional[_F64] = None,
        current_a: Optional[_F64] = None,
        torque_nm: Optional[_F64] = None,
        position_time_s: Optional[_F64] = None,
        effort_time_s: Optional[_F64] = None,
    ) -> None: ...
    @property
    def effort_kind(self) -> str:
        """"current_a" (A) or "torque_nm" (N·m)."""
    @property
    def position_time_s(self) -> _F64:
        """Position sample times (s), a read-only copy."""
    @property
    def position_mm(self) -> _F64:
        """Positions (mm), a read-only copy."""
    @property
    def effort_time_s(self) -> _F64:
        """Effort sample times (s), a read-only copy."""
    @property
    def effort(self) -> _F64:
        """Current (A) or torque (N·m) as effort_kind says, a read-only copy."""
    @property
    def current_a(self) -> Optional[_F64]:
        """Motor current (A), None for a torque trace."""
    @property
    def torque_nm(self) -> Optional[_F64]:
        """Motor torque (N·m), None for a current trace."""
    @property
    def source(self) -> str:
        """The file read, "arrays" or "simulate()"."""
    @property
    def warnings(self) -> List[Dict[str, str]]:
        """What the reader warns about (dropped glitches, a cut last line): dicts of code and
        message (codes in docs/diagnostics.md), as a report's warnings."""
    @property
    def dropped_position(self) -> List[Dict[str, Any]]:
        """Dropped glitch samples: time_s (s), position_mm (mm), line (CSV) or row (Parquet)."""
    @property
    def facts(self) -> Dict[str, Any]:
        """What the recording's source declared (effort_quantum, effort_signed, ...)."""
    def write(self, path: _Path, layout: str = "long") -> None:
        """Write the trace as `feedscope simulate` does: CSV (1 µs, 1 nm, 1 µA / 1 µN·m), or
        Parquet at full precision for a *.parquet name; layout "long" or "wide" (wide needs
        both channels on the same time stamps)."""
    def to_dict(self) -> Dict[str, Any]: ...

def read_trace(path: _Path, axis: Optional[Axis] = None, effort: Optional[str] = None) -> Trace:
    """Read a trace file (CSV long/wide layout, or Parquet) as `feedscope estimate` does.

    With ``axis``, glitches are screened at 1.25 × its rapid_rate_mm_min and positions checked
    against its travel, as every subcommand with --axis does. ``effort="current"`` or
    ``"torque"`` chooses the channel of a file that holds both. Raises BadInputError naming
    the file and line.
    """

class Stroke:
    """One stroke's friction on the resampling grid (one point every lead/samples_per_lead),
    in time order. Arrays are read-only and of equal length."""

    position_mm: _F64
    """Resampled positions (mm)."""
    time_s: _F64
    """Times at those positions (s)."""
    velocity_mm_s: _F64
    """Table velocity (mm/s)."""
    accel_mm_s2: _F64
    """Table acceleration (mm/s²)."""
    effort: _F64
    """Current (A) or torque (N·m), as effort_kind says."""
    friction_n: _F64
    """Friction force F_f (N), Eq. 5, signed."""
    @property
    def current_a(self) -> Optional[_F64]: ...
    @property
    def torque_nm(self) -> Optional[_F64]: ...
    @property
    def effort_kind(self) -> str: ...
    @property
    def stroke(self) -> int:
        """Stroke number (0-based, time order), as in the binary's CSV."""
    @property
    def kind(self) -> str:
        """"measuring", "rapid", "positioning" or "jog"."""
    @property
    def direction(self) -> str:
        """"forward" or "backward"."""
    @property
    def feed_mm_min(self) -> float:
        """Measured plateau feed (mm/min)."""
    @property
    def feed_min_mm_min(self) -> Optional[float]:
        """5th percentile of the stroke's chord speeds (mm/min): low end of its feed range."""
    @property
    def feed_max_mm_min(self) -> Optional[float]:
        """95th percentile of the stroke's chord speeds (mm/min): high end of its feed range."""
    @property
    def start_mm(self) -> float: ...
    @property
    def end_mm(self) -> float: ...
    @property
    def mean_friction_n(self) -> float:
        """Mean friction (N, signed)."""
    @property
    def mean_friction_se_n(self) -> Optional[float]:
        """Standard error of the mean friction (N)."""
    @property
    def friction_std_n(self) -> float:
        """RMS of friction minus its mean (N)."""
    @property
    def max_order(self) -> float:
        """Highest trustworthy order (cycles per lead)."""
    @property
    def position_cutoff_hz(self) -> Optional[float]:
        """Cut-off of the position smoothing (Hz), when applied."""
    @property
    def raw_samples_per_lead(self) -> float: ...
    @property
    def verdict(self) -> Optional[Dict[str, Any]]:
        """What the stroke's data support."""
    @property
    def noise_floor(self) -> Dict[str, Any]:
        """Predicted noise floor (N RMS) and its parts."""
    @property
    def warnings(self) -> List[Dict[str, str]]:
        """Diagnostics: dicts of code and message."""
    @property
    def summary(self) -> Dict[str, Any]:
        """The stroke's entry of the binary's JSON summary."""
    def to_dict(self) -> Dict[str, Any]:
        """The summary's fields and the arrays."""
    def __len__(self) -> int: ...

class EstimateResult:
    """The result of estimate(): strokes and the rest of the binary's JSON summary."""

    strokes: List[Stroke]
    @property
    def effort_kind(self) -> str: ...
    @property
    def verdict(self) -> Dict[str, Any]: ...
    @property
    def moves(self) -> List[Dict[str, Any]]: ...
    @property
    def zones(self) -> List[Dict[str, Any]]: ...
    @property
    def notes(self) -> List[Dict[str, str]]: ...
    @property
    def skipped(self) -> List[str]: ...
    def to_dict(self) -> Dict[str, Any]:
        """The binary's JSON summary (OUT.json of feedscope estimate)."""
    def to_pandas(self) -> Any:
        """The friction CSV's rows as a pandas DataFrame (needs pandas)."""
    def __len__(self) -> int: ...

def estimate(
    trace: Trace,
    axis: Axis,
    *,
    samples_per_lead: int = 1024,
    end_condition: str = "not-a-knot",
    time_of_position: str = "invert",
    position_cutoff_hz: Union[None, str, float] = None,
    include_rapids: bool = False,
    effort_sign: str = "auto",
    program: Optional[_Path] = None,
    program_axis: str = "Z",
) -> EstimateResult:
    """Friction along the travel for every measuring stroke (paper 000, Eq. 5), as
    `feedscope estimate`. samples_per_lead: points per lead; end_condition: "not-a-knot" or
    "natural"; time_of_position: "invert" or "knot-spline"; position_cutoff_hz: None/"auto",
    "off" or a cut-off (Hz); effort_sign: "auto", "signed", "magnitude" or "negated"; program: the NC
    program that made the trace, program_axis its axis letter. Releases the GIL."""

class StrokeProfile:
    """One analysed stroke: its friction, the IAFV and FFS (N) on the same grid."""

    stroke: Stroke
    iafv_n: _F64
    """Instantaneous average friction value (N)."""
    ffs_n: _F64
    """Friction fluctuating signal, friction − IAFV (N)."""
    @property
    def components(self) -> List[Dict[str, Any]]:
        """Significant components: segment, order (cycles per lead), amplitude_n, floor_n,
        cause, trusted."""
    @property
    def iafv(self) -> Dict[str, Any]: ...
    @property
    def fluctuation(self) -> Dict[str, Any]: ...
    @property
    def order_scan(self) -> Dict[str, Any]: ...
    def to_dict(self) -> Dict[str, Any]: ...

class AnalyzeResult:
    """The result of analyze(); to_dict() is the binary's analysis.json."""

    strokes: List[StrokeProfile]
    @property
    def order_scan_table(self) -> Dict[str, Any]:
        """Paper 000 Table 2: residual std (N) of single polynomials per order and direction."""
    @property
    def withheld(self) -> List[Dict[str, Any]]: ...
    @property
    def verdict(self) -> Optional[Dict[str, Any]]: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def __len__(self) -> int: ...

def analyze(
    trace: Trace,
    axis: Axis,
    *,
    samples_per_lead: int = 1024,
    breaks_mm: Optional[Sequence[float]] = None,
    orders: Optional[Sequence[int]] = None,
    segments: Optional[int] = None,
    segment_length_mm: Optional[float] = None,
) -> AnalyzeResult:
    """Mean friction profile (IAFV) and fluctuation spectra in screw orders (paper 000,
    Section 4.1), as `feedscope analyze`. breaks_mm: IAFV interior breakpoints (mm) with
    orders, one per interval; segments or segment_length_mm (mm) for the segment spectra.
    Releases the GIL."""

class Simulation:
    """The digital twin's output: trace, axis and the known truth (arrays every
    truth.interval_ms)."""

    trace: Trace
    axis: Axis
    truth_time_s: _F64
    """Times of the true state (s)."""
    truth_position_mm: _F64
    """True table position (mm)."""
    truth_velocity_mm_s: _F64
    """True table velocity (mm/s)."""
    truth_accel_mm_s2: _F64
    """True table acceleration (mm/s²)."""
    truth_friction_n: _F64
    """True friction (N, signed)."""
    def truth(self) -> Dict[str, Any]:
        """The binary's truth.json."""
    def true_friction_n(self, position_mm: Any, velocity_mm_s: Any) -> _F64:
        """The twin's friction model (N, signed) at positions (mm) and velocities (mm/s)."""
    def to_dict(self) -> Dict[str, Any]: ...

def simulate(config: Union[None, Dict[str, Any], _Path] = None, *, seed: Optional[int] = None) -> Simulation:
    """The digital twin, as `feedscope simulate`: config as a dict of the TOML's keys or a
    TOML file's path (None: the default lathe Z, 0 → 410 → 0 mm at 100 mm/min); seed
    overrides the config's. Releases the GIL."""

def default_sim_config() -> str:
    """The default simulator config as TOML (every key with its unit)."""

class Plan:
    """An NC program of a friction test: ``text`` (G-code as `feedscope plan` writes it) and
    its summary (the binary's --format json without ``output``)."""

    text: str
    @property
    def run_time_s(self) -> float:
        """Expected run time (s)."""
    @property
    def samples_per_channel(self) -> int:
        """Expected samples per channel at the sampling interval given."""
    @property
    def feeds_mm_min(self) -> List[float]:
        """Feeds of the test in order (mm/min)."""
    @property
    def moves(self) -> List[Dict[str, Any]]: ...
    @property
    def notes(self) -> List[str]: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def write(self, path: _Path) -> None:
        """Write the program text to a file."""

def plan_strokes(
    from_mm: float,
    to_mm: float,
    feeds_mm_min: Sequence[float],
    *,
    repeats: int = 3,
    dwell_s: float = 1.0,
    axis: Optional[Axis] = None,
    travel_min_mm: Optional[float] = None,
    travel_max_mm: Optional[float] = None,
    feed_limit_mm_min: Optional[float] = None,
    dialect: str = "fanuc",
    fanuc_machine: str = "lathe",
    axis_letter: str = "Z",
    program_number: int = 1000,
    approach_feed_mm_min: Optional[float] = None,
    accel_mm_s2: float = 1000.0,
    sample_interval_ms: float = 72.0,
    sample_rate_hz: Optional[float] = None,
    ramp: str = "jerk_limited",
    jerk_mm_s3: Optional[float] = None,
) -> Plan:
    """A stroke test (paper 000), as `feedscope plan strokes`: strokes from_mm → to_mm (mm)
    and back at each feed (mm/min), repeats pairs per feed, dwell_s (s) after each. Travel
    limits from axis or travel_min_mm/travel_max_mm; dialect "fanuc" or "siemens"; the run
    time assumes ramp ("jerk_limited", "trapezoid" or "bell") and jerk_mm_s3 (mm/s³)."""

def plan_triangle(
    *,
    from_mm: Optional[float] = None,
    to_mm: Optional[float] = None,
    feed_max_mm_min: Optional[float] = None,
    feed_min_mm_min: Optional[float] = None,
    vs_guess_mm_min: float = 60.0,
    levels: int = 10,
    cycles: int = 1,
    cruise_s: float = 2.0,
    dwell_s: float = 0.0,
    axis: Optional[Axis] = None,
    travel_min_mm: Optional[float] = None,
    travel_max_mm: Optional[float] = None,
    feed_limit_mm_min: Optional[float] = None,
    dialect: str = "fanuc",
    fanuc_machine: str = "lathe",
    axis_letter: str = "Z",
    program_number: int = 1000,
    approach_feed_mm_min: Optional[float] = None,
    accel_mm_s2: float = 1000.0,
    sample_interval_ms: float = 72.0,
    sample_rate_hz: Optional[float] = None,
    ramp: str = "jerk_limited",
    jerk_mm_s3: Optional[float] = None,
) -> Plan:
    """A triangle test (paper 002 Eq. 8), as `feedscope plan triangle`: a variable-amplitude,
    variable-velocity triangular wave in from_mm..to_mm (mm), feeds geometric from
    feed_min_mm_min to feed_max_mm_min (mm/min) over levels, cruising cruise_s (s)."""

def plan(test: str, **kwargs: Any) -> Plan:
    """plan("strokes", ...) is plan_strokes(...); plan("triangle", ...) is plan_triangle(...)."""

class StribeckResult:
    """Stribeck fits per direction; to_dict() is the binary's stribeck.json. Parameters in
    user units: fc_n (N), fs_n (N), vs_mm_min (mm/min), sigma_n_s_per_m (N·s/m), delta."""

    @property
    def directions(self) -> List[Dict[str, Any]]: ...
    def direction(self, name: str) -> Optional[Dict[str, Any]]:
        """The fit of "forward" or "backward", None when absent."""
    def to_dict(self) -> Dict[str, Any]: ...

def fit_stribeck(
    table: Optional[_Path] = None,
    *,
    feed_mm_min: Optional[_F64] = None,
    force_n: Optional[_F64] = None,
    torque_nm: Optional[_F64] = None,
    direction: Optional[Sequence[str]] = None,
    lead_mm: Optional[float] = None,
    axis: Optional[Axis] = None,
    efficiency: float = 1.0,
    delta: Union[None, float, str] = None,
    noise_n: Optional[float] = None,
) -> StribeckResult:
    """F(v) = Fc + (Fs − Fc)·exp(−(|v|/vs)^δ) + σ·|v| per direction (paper 000 Eq. 9), as
    `feedscope fit-stribeck`: from a CSV table or arrays (feed_mm_min in mm/min; force_n in N
    or torque_nm in N·m with lead_mm/axis and efficiency, Eq. 15). delta: a number (default
    2) or "free"; noise_n (N) for the non-conventional check."""

class IdentifyResult:
    """One-test identification (paper 002); to_dict() is the binary's ident.json.
    motor: j_total_kgm2 (kg·m²), tc_nm, ts_nm (N·m), vs_mm_min (mm/min), sigma_nm_s_per_m
    (N·m·s/m), offset_nm (N·m), delta; force: fc_n, fs_n (N), sigma_n_s_per_m (N·s/m),
    equivalent_mass_kg (kg)."""

    time_s: _F64
    """Times of the kernel averages (s)."""
    measured_torque_nm: _F64
    """Kernel-averaged measured motor torque (N·m)."""
    computed_torque_nm: _F64
    """Torque of the fitted model, J·θ'' + T_f(v) (N·m)."""
    used: npt.NDArray[np.bool_]
    """Rows used in the fit."""
    @property
    def motor(self) -> Dict[str, float]: ...
    @property
    def std_error(self) -> Dict[str, float]: ...
    @property
    def force(self) -> Dict[str, float]: ...
    @property
    def diagnostics(self) -> Dict[str, Any]: ...
    @property
    def warnings(self) -> List[Dict[str, str]]: ...
    @property
    def compare(self) -> Optional[Dict[str, Any]]: ...
    def to_dict(self) -> Dict[str, Any]: ...

def identify(
    trace: Trace,
    axis: Axis,
    *,
    kernel_s: Optional[float] = None,
    min_speed_mm_min: float = 1.0,
    guard_s: Optional[float] = None,
    delta: float = 2.0,
    vs_min_mm_min: float = 0.5,
    vs_max_mm_min: float = 5000.0,
    fit_offset: bool = True,
    compare: Optional[Trace] = None,
) -> IdentifyResult:
    """J, Tc, Ts, vs, σ (and T0) from one triangular-wave test (paper 002), as
    `feedscope identify`; compare: a constant-feed stroke trace fitted for comparison.
    Releases the GIL."""

class DynamicsResult:
    """Modal analysis of a feed drive; to_dict() is the binary's dynamics.json."""

    @property
    def static_first_hz(self) -> float:
        """First natural frequency at rest (Hz)."""
    @property
    def breakaway_first_hz(self) -> float:
        """First natural frequency just after breakaway (Hz)."""
    @property
    def peak_first_hz(self) -> float:
        """Highest first natural frequency over the feed sweep (Hz)."""
    @property
    def peak_feed_mm_min(self) -> float:
        """Feed of that peak (mm/min)."""
    @property
    def bearing_unload(self) -> Optional[Dict[str, Any]]: ...
    @property
    def resonances(self) -> List[Dict[str, Any]]:
        """Ripple resonance risks: harmonic, feed_mm_min, frequency_hz, mode, margin_hz, ..."""
    @property
    def feed_mm_min(self) -> _F64:
        """Feeds of the sweep (mm/min)."""
    @property
    def frequency_vs_feed_hz(self) -> npt.NDArray[np.float64]:
        """Natural frequencies (Hz), one row per feed, one column per mode."""
    def to_dict(self) -> Dict[str, Any]: ...

def dynamics(config: Union[_Path, Dict[str, Any]]) -> DynamicsResult:
    """Natural frequency vs feed rate and nut position, torque-ripple resonances, as
    `feedscope dynamics --config FILE`: the drive file's path or a dict of its keys
    (examples/drive.toml). Releases the GIL."""

class HistoryEntry:
    """What History.add stored; to_dict() is the binary's `history add --format json`."""

    id: int
    duplicate: bool
    @property
    def indicators(self) -> List[Dict[str, Any]]:
        """Indicator values of the test: indicator, value (in its unit), std_error."""
    def to_dict(self) -> Dict[str, Any]: ...

class TrendResult:
    """Trends and diagnosis of an axis; to_dict() is the binary's `history trend --format
    json`; warning is True when any indicator is not ok."""

    warning: bool
    @property
    def trends(self) -> List[Dict[str, Any]]: ...
    @property
    def diagnosis(self) -> List[str]: ...
    @property
    def profiles(self) -> Optional[Dict[str, Any]]: ...
    @property
    def tests(self) -> List[Dict[str, Any]]: ...
    def to_dict(self) -> Dict[str, Any]: ...

class History:
    """The condition history in an SQLite database (created when missing), as
    `feedscope history --db PATH`."""

    def __init__(self, path: _Path) -> None: ...
    def add(
        self,
        trace: _Path,
        axis: Union[Axis, _Path],
        kind: str,
        *,
        time: Optional[str] = None,
        machine: str = "machine",
        axis_name: Optional[str] = None,
        program: Optional[str] = None,
        compensation: Optional[str] = None,
        reference: bool = False,
        interval_mm: Optional[float] = None,
    ) -> HistoryEntry:
        """Analyse a test trace file ("strokes" or "triangle") and store it; time is RFC 3339
        (default: the file's modification time); interval_mm (mm) the width of the
        mean-friction intervals. Releases the GIL."""
    def list(self, *, machine: Optional[str] = None, axis_name: Optional[str] = None) -> List[Dict[str, Any]]:
        """The stored tests."""
    def trend(
        self,
        *,
        machine: str = "machine",
        axis_name: Optional[str] = None,
        baseline_tests: Optional[int] = None,
        thresholds: Optional[_Path] = None,
        profile_baseline_tests: Optional[int] = None,
        profile_limit_sigma: Optional[float] = None,
        component_false_alarm: Optional[float] = None,
    ) -> TrendResult:
        """Trends of every indicator of an axis and their diagnosis (defaults as the
        binary's: baseline of the first 5 tests, ...)."""

class MapResult:
    """The friction map of a test set (paper 000, Section 4.2); to_dict() is the binary's
    map.json, stribeck() its stribeck.json (fc_n, fs_n in N, vs_mm_min in mm/min,
    sigma_n_s_per_m in N·s/m at each position)."""

    @property
    def summary(self) -> Dict[str, Any]:
        """Runs, failed runs, per direction span (mm), breakpoints, feeds (mm/min), misfits (N)."""
    @property
    def failed(self) -> List[Dict[str, str]]:
        """Runs that could not be estimated: file, error."""
    def stribeck(self) -> Dict[str, Any]: ...
    def to_dict(self) -> Dict[str, Any]: ...

def map(
    index: _Path,
    axis: Axis,
    *,
    positions_mm: Optional[Sequence[float]] = None,
    breaks_mm: Optional[Sequence[float]] = None,
    orders: Optional[Sequence[int]] = None,
    feed_order: Optional[int] = None,
    feed_scale: str = "log",
    position_step_mm: Optional[float] = None,
    table_feeds_mm_min: Optional[Sequence[float]] = None,
    extrapolate: bool = False,
    margin_mm: Optional[float] = None,
    samples_per_lead: int = 1024,
) -> MapResult:
    """Friction map F(z, v) of a test set (index CSV: file,feed_mm_min,repeat), as `feedscope
    map` (map.json and stribeck.json; no CSV tables, plots or --export files). positions_mm,
    breaks_mm, margin_mm, position_step_mm in mm; feeds in mm/min. Releases the GIL."""
