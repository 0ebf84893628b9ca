"""Type stubs of the gonio package."""

import os
from typing import Any, Dict, Tuple, Union

from ._gonio import (
    Error as Error,
    __version__ as __version__,
    check as check,
    eval as eval,
    load as load,
    material as material,
    materials as materials,
    read_manifest as read_manifest,
    run_entry as run_entry,
    save as save,
    tabulate as tabulate,
)

def fit(
    samples: Union[str, "os.PathLike[str]", Dict[str, Any]],
    model: Union[str, Dict[str, Any]] = ...,
    residual: Union[str, None] = ...,
    max_samples: Union[int, None] = ...,
    truth: Union[str, Dict[str, Any], None] = ...,
    **options: Any,
) -> Tuple[Dict[str, Any], Dict[str, Any]]: ...
def load_campaign(folder: Union[str, "os.PathLike[str]"]) -> Dict[str, Any]: ...
