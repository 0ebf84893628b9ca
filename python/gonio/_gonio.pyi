"""Type stubs of the compiled core gonio._gonio (re-exported by the gonio package)."""

import os
from typing import Any, Dict, List, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

class Error(ValueError):
    """An expected failure of the C++ libraries; the message is the command line's."""

PathLike = Union[str, "os.PathLike[str]"]
#: A model dict (docs/model-schema.md), a table dict from load()/tabulate(), a path
#: (*.json model, *.binary/*.merl/*.gtab table) or "material:NAME".
BrdfLike = Union[PathLike, Dict[str, Any]]
ArrayLike = npt.ArrayLike

@overload
def eval(model: BrdfLike, wi: ArrayLike, wo: ArrayLike) -> npt.NDArray[np.float64]: ...
@overload
def eval(
    model: BrdfLike,
    theta_i: ArrayLike,
    phi_i: ArrayLike,
    theta_o: ArrayLike,
    phi_o: ArrayLike,
) -> npt.NDArray[np.float64]: ...
def load(path: PathLike, samples: bool = ..., keep_going: bool = ...) -> Dict[str, Any]: ...
def save(path: PathLike, data: Union[BrdfLike, Dict[str, Any]]) -> None: ...
def tabulate(model: BrdfLike, grid: Sequence[int] = ...) -> Dict[str, Any]: ...
def check(
    model: BrdfLike,
    seed: int = ...,
    pairs: int = ...,
    reciprocity_tol: float = ...,
    isotropy_tol: float = ...,
    energy_tol: float = ...,
) -> Dict[str, Any]: ...
def materials(library: Union[PathLike, None] = ...) -> List[str]: ...
def material(name: str) -> Dict[str, Any]: ...
def read_manifest(path: str) -> List[Dict[str, Any]]: ...
def run_entry(id: str, input: str, options: str, out_dir: str) -> Dict[str, Any]: ...
def summary_header() -> str: ...
def write_text_atomically(path: str, text: str) -> None: ...
def _fit(
    samples: Union[PathLike, Dict[str, Any]],
    model: Union[str, Dict[str, Any]],
    residual: Union[str, None],
    max_samples: Union[int, None],
    truth: Union[BrdfLike, None],
    options: Dict[str, Any],
) -> Tuple[Dict[str, Any], Dict[str, Any]]: ...
