"""Type hints of the compiled module (Rust, pyo3); use the wrappers in ``ptconsensus``."""

from typing import Callable, Dict, List, Optional, Tuple

import numpy as np

def run(
    kind: str,
    source: str,
    sets: List[str],
    out: Optional[str] = None,
    format: str = "csv",
    plots: bool = False,
    decimate: Optional[int] = None,
    agents: Optional[str] = None,
    table: bool = True,
    force: bool = False,
    progress: Optional[Callable[[int, int], None]] = None,
) -> Tuple[str, Optional[Dict[str, np.ndarray]]]: ...
def sweep(
    campaign: str,
    out: str,
    shard: Optional[str] = None,
    format: str = "csv",
    progress: Optional[Callable[[int, int], None]] = None,
) -> Dict[str, list]: ...

class Controller:
    def __init__(self, kind: str, source: str, sets: List[str], agent: int) -> None: ...
    @property
    def n(self) -> int: ...
    @property
    def m(self) -> int: ...
    @property
    def h(self) -> float: ...
    @property
    def k(self) -> int: ...
    @property
    def neighbours(self) -> List[int]: ...
    @property
    def pinned(self) -> bool: ...
    def step(
        self, x: List[float], neighbours: List[Optional[float]], leader: Optional[float] = None
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, float, float, float, Optional[str]]: ...
    def reset(self) -> None: ...
