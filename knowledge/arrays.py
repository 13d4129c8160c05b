"""Read-only numpy arrays for the frozen types: one helper, with the shape and finiteness checks.

Every frozen dataclass that holds an array (a pose, an axis, a trajectory, a record) stores a
private copy with its write flag cleared, so that the object cannot change after it was
checked; :func:`readonly_array` makes that copy.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import DTypeLike

_LISTED = 16
"""A non-finite array of at most this many entries is listed in the error; a larger one is
counted (a trajectory has thousands)."""


def readonly_array(value: Any, shape: tuple[int, ...] | None = None, name: str = "array", *,
                   finite: bool = False, dtype: DTypeLike | None = float) -> np.ndarray:
    """A read-only copy of ``value``.

    Parameters
    ----------
    value : array-like
    shape : tuple of int, optional
        The shape expected (no check when None).
    name : str
        How the error names the value (e.g. ``"T_part_piece"``).
    finite : bool
        Refuse NaN and infinity.
    dtype : numpy dtype
        Element type of the copy (default float; None keeps the input's).

    Raises
    ------
    ValueError
        A shape other than ``shape``, or a non-finite entry when ``finite``.
    """
    arr = np.array(value, dtype=dtype)
    if shape is not None and arr.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, found {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        found = arr.tolist() if arr.size <= _LISTED else f"{bad} NaN or inf entries"
        raise ValueError(f"{name}: expected finite numbers, found {found}")
    arr.setflags(write=False)
    return arr


__all__ = ["readonly_array"]
