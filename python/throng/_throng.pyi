"""Type stubs of the native module ``throng._throng`` (re-exported by ``throng``)."""

from os import PathLike
from typing import Any, Dict, List, Literal, Mapping, Optional, Tuple, TypedDict, Union, final, type_check_only

import numpy as np
import numpy.typing as npt
import pandas as pd

__all__ = [
    "Journey",
    "QueueStage",
    "Simulation",
    "ThrongError",
    "Transition",
    "WaitingSetStage",
    "World",
    "bench",
    "scenarios",
    "validate",
    "__version__",
]
__version__: str

_Order = Literal["storage", "id"]
_Pairs = npt.ArrayLike
_F32Pairs = np.ndarray  # (N, 2) float32

class ThrongError(ValueError):
    """A bad argument or scenario; the message is the Rust library's and names the parameter."""

    parameter: Optional[str]

@type_check_only
class StepStats(TypedDict):
    """What ``World.step`` returns: the keys of the CLI's frame line (milliseconds)."""

    frame: int
    step: float
    index: float
    steer: float
    integrate: float
    bounds: float
    fields: float
    formations: float
    measure: float
    agents: int
    mean_neighbours: float

@type_check_only
class MsPerStep(TypedDict):
    median: float
    mean: float
    p95: float
    p99: float
    min: float
    max: float

@type_check_only
class LineReport(TypedDict):
    """A counting line's summary: crossings each way, flow J, specific flow J/b, time gaps, and
    the N-t diagram's count and flow (each agent once, at its first crossing, as PedPy)."""

    name: str
    positive: int
    negative: int
    net: int
    total: int
    first_time: Optional[float]
    last_time: Optional[float]
    flow: Optional[float]
    nt_count: int
    nt_flow: Optional[float]
    specific_flow: Optional[float]
    length: float
    time_gap_mean: Optional[float]
    time_gap_sd: Optional[float]

@type_check_only
class AreaReport(TypedDict):
    """A measurement area's summary: means over the frames of the window."""

    name: str
    area: float
    frames: int
    mean_count: Optional[float]
    mean_density: Optional[float]
    mean_speed: Optional[float]
    mean_voronoi_density: Optional[float]
    mean_voronoi_speed: Optional[float]

@type_check_only
class MeasurementReport(TypedDict):
    lines: List[LineReport]
    areas: List[AreaReport]
    left: int

@type_check_only
class BenchReport(TypedDict):
    """What ``bench`` returns: the keys of ``throng bench --json``."""

    scenario: str
    agents: int
    threads: int
    index: str
    steps: int
    ms_per_step: MsPerStep
    phases_ms: Dict[str, float]
    agent_steps_per_sec: float
    mean_neighbours: float
    polarisation: float
    peak_rss_mb: float
    arrived: int
    all_arrived_step: Optional[int]
    evacuation_time: Optional[float]
    measurements: MeasurementReport

@type_check_only
class Bounds(TypedDict):
    kind: Literal["torus", "bounded", "open"]
    size: Optional[Tuple[float, float]]

_StageRef = Union[int, "QueueStage", "WaitingSetStage"]
_Polygon = Any  # WKT text, a shapely geometry, or a sequence of (x, y) points

@final
class Transition:
    """How an agent that completed a stage chooses its next."""

    @staticmethod
    def fixed(stage: _StageRef) -> Transition: ...
    @staticmethod
    def round_robin(weighted: List[Tuple[_StageRef, int]]) -> Transition: ...
    @staticmethod
    def least_targeted(stages: List[_StageRef]) -> Transition: ...

@final
class Journey:
    """Stages, and a transition out of each stage that does not end the journey."""

    def __new__(cls, stages: List[_StageRef], *, chain: bool = False) -> Journey: ...
    def set_transition(self, stage: _StageRef, transition: Transition) -> None: ...
    def set_transition_for_stage(self, stage: _StageRef, transition: Transition) -> None: ...
    @property
    def stages(self) -> List[int]: ...

@final
class QueueStage:
    """A queue stage: ``pop(n)`` releases the first ``n`` in its slots."""

    @property
    def id(self) -> int: ...
    def pop(self, n: int) -> None: ...
    def enqueued(self) -> List[int]: ...
    def count_enqueued(self) -> int: ...
    def count_targeting(self) -> int: ...

@final
class WaitingSetStage:
    """A waiting set stage: holds everyone in its slots while ``active``."""

    @property
    def id(self) -> int: ...
    @property
    def active(self) -> bool: ...
    @active.setter
    def active(self, active: bool) -> None: ...
    def waiting(self) -> List[int]: ...
    def count_waiting(self) -> int: ...
    def count_targeting(self) -> int: ...

@final
class Simulation:
    """A pedestrian study on a walkable area with stages, journeys and agents, no TOML."""

    def __new__(
        cls,
        geometry: _Polygon,
        *,
        model: str = "cfsm",
        dt: float = 0.01,
        seed: int = 1,
        threads: Optional[int] = None,
        params: Optional[Mapping[str, Any]] = None,
    ) -> Simulation: ...
    def add_waypoint_stage(self, position: Tuple[float, float], distance: float) -> int: ...
    def add_exit_stage(self, polygon: _Polygon) -> int: ...
    def add_queue_stage(self, positions: _Pairs) -> QueueStage: ...
    def add_waiting_set_stage(self, positions: _Pairs) -> WaitingSetStage: ...
    def add_direct_steering_stage(self) -> int: ...
    def add_journey(self, journey: Journey) -> int: ...
    def add_agents(
        self,
        positions: Any,
        *,
        journey: Optional[int] = None,
        stage: Optional[_StageRef] = None,
        desired_speed: Optional[Any] = None,
        radius: Optional[Any] = None,
        model: Optional[str] = None,
        **params: Any,
    ) -> Any: ...
    def iterate(self, n: int = 1) -> None: ...
    def agent_count(self) -> int: ...
    def elapsed_time(self) -> float: ...
    def iteration_count(self) -> int: ...
    @property
    def dt(self) -> float: ...
    def exit_counts(self) -> Dict[int, int]: ...
    def ids(self) -> np.ndarray: ...
    def positions(self) -> _F32Pairs: ...
    def velocities(self) -> _F32Pairs: ...
    def desired_speeds(self) -> np.ndarray: ...
    def radii(self) -> np.ndarray: ...
    def set_desired_speeds(self, ids: Any, values: Any) -> None: ...
    def set_radii(self, ids: Any, values: Any) -> None: ...
    def agent_params(self, name: str) -> np.ndarray: ...
    def set_agent_params(self, ids: Any, name: str, values: Any) -> None: ...
    def agent_journey(self, id: int) -> Optional[Tuple[int, int]]: ...
    def switch_agent_journey(self, id: int, journey: int, stage: Optional[_StageRef] = None) -> None: ...
    def set_direct_target(self, id: int, position: Tuple[float, float]) -> None: ...
    def remove_agent(self, id: int) -> None: ...
    def set_external(self, ids: Any, positions: _Pairs, velocities: Optional[_Pairs] = None) -> None: ...
    def switch_geometry(self, geometry: _Polygon) -> None: ...
    def stranded_agents(self) -> np.ndarray: ...
    def save(self, path: Union[str, PathLike]) -> None: ...
    @staticmethod
    def load(path: Union[str, PathLike], *, threads: Optional[int] = None) -> Simulation: ...
    def walkable_area(self, *, shapely: bool = False) -> Any: ...
    def record(self, path: Union[str, PathLike], every: int = 1) -> None: ...
    def close(self) -> None: ...

@final
class World:
    """A simulated world: agents, groups, bounds, obstacles, gravity points and fields.

    Arrays are fresh copies (or fill ``out=``), rows in storage order unless ``order="id"``.
    """

    @staticmethod
    def from_scenario(
        name: str,
        *,
        agents: Optional[int] = None,
        seed: Optional[int] = None,
        threads: Optional[int] = None,
        **overrides: Any,
    ) -> World: ...
    @staticmethod
    def from_toml(
        path_or_text: Union[str, PathLike],
        *,
        agents: Optional[int] = None,
        seed: Optional[int] = None,
        threads: Optional[int] = None,
        **overrides: Any,
    ) -> World: ...
    def __len__(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def frame(self) -> int: ...
    @property
    def time(self) -> float: ...
    @property
    def seed(self) -> int: ...
    @property
    def steps(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @dt.setter
    def dt(self, dt: float) -> None: ...
    @property
    def threads(self) -> int: ...
    @property
    def index(self) -> Literal["grid", "kdtree", "brute"]: ...
    @index.setter
    def index(self, index: str) -> None: ...
    @property
    def reorder_every(self) -> int: ...
    @reorder_every.setter
    def reorder_every(self, frames: int) -> None: ...
    @property
    def bounds(self) -> Bounds: ...
    @property
    def group_names(self) -> List[str]: ...
    @property
    def field_count(self) -> int: ...
    def step(self, dt: Optional[float] = None, n: int = 1) -> StepStats: ...
    def positions(self, out: Optional[np.ndarray] = None, *, order: _Order = "storage") -> _F32Pairs: ...
    def velocities(self, out: Optional[np.ndarray] = None, *, order: _Order = "storage") -> _F32Pairs: ...
    def orientations(self, out: Optional[np.ndarray] = None, *, order: _Order = "storage") -> np.ndarray: ...
    def ids(self, out: Optional[np.ndarray] = None, *, order: _Order = "storage") -> np.ndarray: ...
    def groups(self, out: Optional[np.ndarray] = None, *, order: _Order = "storage") -> np.ndarray: ...
    def arrived(self, out: Optional[np.ndarray] = None, *, order: _Order = "storage") -> np.ndarray: ...
    def arrived_count(self) -> int: ...
    def mean_speed(self) -> float: ...
    def polarisation(self) -> float: ...
    def add_agents(
        self,
        positions: _Pairs,
        velocities: Optional[_Pairs] = None,
        *,
        group: Optional[npt.ArrayLike] = None,
        orientations: Optional[npt.ArrayLike] = None,
        max_speed: Optional[npt.ArrayLike] = None,
        radius: Optional[npt.ArrayLike] = None,
    ) -> np.ndarray: ...
    def remove_agents(self, ids: npt.ArrayLike) -> None: ...
    def set_positions(self, ids: npt.ArrayLike, positions: _Pairs) -> None: ...
    def set_velocities(self, ids: npt.ArrayLike, velocities: _Pairs) -> None: ...
    def set_targets(self, ids: npt.ArrayLike, targets: _Pairs) -> None: ...
    def set_max_speeds(self, ids: npt.ArrayLike, max_speed: npt.ArrayLike) -> None: ...
    def group_params(self, group: int) -> Dict[str, Any]: ...
    def set_group_params(self, group: int, params: Dict[str, Any]) -> None: ...
    def add_group(self, params: Dict[str, Any]) -> int: ...
    def add_circle(self, center: Tuple[float, float], radius: float) -> None: ...
    def add_wall(self, a: Tuple[float, float], b: Tuple[float, float]) -> None: ...
    def add_polygon(self, points: _Pairs, closed: bool = True) -> None: ...
    def add_gravity_point(
        self,
        position: Tuple[float, float],
        strength: float,
        radius: float,
        *,
        exponent: float = 2.0,
        motion: Optional[Dict[str, Any]] = None,
    ) -> int: ...
    def gravity_positions(self) -> _F32Pairs: ...
    def set_gravity_position(self, k: int, position: Tuple[float, float]) -> None: ...
    def set_field_goals(self, field: int, channel: int, goals: npt.ArrayLike) -> None: ...
    def randomize_field_goals(self, field: int, channel: int, n: int, seed: int) -> None: ...
    def shuffle_field_goals_every(self, field: int, every: int, count: int) -> None: ...
    def set_field_blocked(self, field: int, x: int, y: int, blocked: bool = True) -> None: ...
    def trajectories(self, steps: int, every: int = 1, *, dt: Optional[float] = None) -> pd.DataFrame: ...
    def measurements(self) -> MeasurementReport: ...
    @property
    def evacuation_time(self) -> Optional[float]: ...

def bench(
    scenario: str,
    *,
    agents: Optional[int] = None,
    steps: int = 100,
    warmup: int = 10,
    threads: Optional[int] = None,
    seed: Optional[int] = None,
    dt: Optional[float] = None,
    index: Optional[str] = None,
    **overrides: Any,
) -> BenchReport: ...
def scenarios() -> Dict[str, str]: ...
def _panic(message: str) -> None:
    """Panics inside the module's panic guard (the tests' check that a panic is a ThrongError)."""
def validate(
    case: str,
    *,
    quick: bool = False,
    model: Optional[str] = None,
    seed_offset: int = 0,
    threads: Optional[int] = None,
    params: Optional[Mapping[str, Any]] = None,
) -> Dict[str, Any]: ...
