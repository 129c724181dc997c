"""Argument checks shared by pkmlab's public functions: every one turns a bad argument into one
:class:`~pkmlab.errors.InvalidParameterError` line that names the argument (and, in a batch, the index).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from .errors import InvalidParameterError, shown


def as_batch(name: str, value, n: int, *, single: bool = False) -> tuple[np.ndarray, tuple[int, ...]]:
    """``value`` as a C-contiguous ``(N, n)`` float array, and its leading shape.

    ``single=True`` accepts exactly one vector, shape ``(n,)`` (the leading shape is then ``()``).
    """
    arr = real_array(name, value)
    if single and arr.shape != (n,):
        raise InvalidParameterError(f"{name} must be {n} numbers (shape ({n},)), got shape {arr.shape}")
    if arr.ndim == 0 or arr.shape[-1] != n:
        raise InvalidParameterError(f"{name} must have {n} components (shape (..., {n})), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise InvalidParameterError(f"{name} must be finite, got {arr[tuple(bad)]} at index {tuple(bad.tolist())}")
    return _kernel_input(arr.reshape(-1, n)), arr.shape[:-1]


#: What NumPy would convert to a float, wrongly: text, truth values and complex numbers.
_NOT_REAL = (str, bytes, bool, np.bool_, complex, np.complexfloating)


def real_array(name: str, value, what: str = "real numbers") -> np.ndarray:
    """``value`` as a float array of any shape, or one :class:`InvalidParameterError` line naming ``name``.

    Only numbers are numbers: text (``"0.1667"``, ``["1", "2"]``), truth values (``True``, a boolean mask) and
    complex values are refused, not converted — NumPy would read ``"0.1667"`` as 0.1667, ``True`` as 1 and drop
    an imaginary part, so a slip would give an answer instead of an error.
    """
    def wrong() -> InvalidParameterError:  # written only when refused: the repr of a large array costs milliseconds
        return InvalidParameterError(f"{name} must be {what}, got {shown(value)}")

    if isinstance(value, (str, bytes, bool, np.bool_, dict, set)):
        raise wrong()
    try:
        raw = np.asarray(value)
        # a list mixing kinds is converted to a common one ([True, 1.0] to floats): look at each of its items
        items = raw if isinstance(value, np.ndarray) else np.asarray(value, dtype=object)
        if items.dtype.kind == "O" and any(isinstance(v, _NOT_REAL) for v in items.reshape(-1)):
            raise TypeError
        if raw.dtype.kind not in "iufO":  # text, truth values, complex, dates...
            raise TypeError
        return np.asarray(raw, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise wrong() from None


def _kernel_input(arr: np.ndarray) -> np.ndarray:
    """``arr`` as the compiled kernels take every input but the parameters: C-contiguous and writable (a copy
    only when it is not). One layout for every caller: Numba compiles a kernel once per layout and
    writability of its arguments, and a spatial machine's kernel takes tens of seconds to compile."""
    return np.require(arr, dtype=float, requirements=("C", "W"))


def as_broadcast(*specs) -> tuple:
    """Validate ``(name, value, n)`` arrays and broadcast their leading shapes together.

    Returns each as a C-contiguous ``(N, n)`` array, then the common leading shape.
    """
    arrays, shapes = [], []
    for name, value, n in specs:
        arr, shape = as_batch(name, value, n)
        arrays.append((arr, n))
        shapes.append(shape)
    try:
        shape = np.broadcast_shapes(*shapes)
    except ValueError:
        listing = " and ".join(f"{spec[0]} {s}" for spec, s in zip(specs, shapes, strict=True))
        raise InvalidParameterError(f"{listing} do not broadcast") from None
    full = [
        _kernel_input(np.broadcast_to(arr.reshape(*s, n), (*shape, n)).reshape(-1, n))
        for (arr, n), s in zip(arrays, shapes, strict=True)
    ]
    return (*full, shape)


def as_pair(name_a: str, a, n_a: int, name_b: str, b, n_b: int):
    return as_broadcast((name_a, a, n_a), (name_b, b, n_b))


def index_text(flat: int, shape: tuple[int, ...]) -> str:
    return "" if shape == () else f" at index {tuple(int(i) for i in np.unravel_index(flat, shape))}"


def as_mode(mode, name: str = "mode", count: int = 3) -> np.ndarray:
    """A working mode as an int64 array of ``count`` signs (three for the 3-RRR), from ``"+-+"``,
    ``("+", "-", "+")``, ``(1, -1, 1)``..."""
    symbols = {"+": 1, "-": -1, "+1": 1, "-1": -1, "1": 1}
    try:
        values = [symbols.get(m, m) if isinstance(m, str) else m for m in mode]
        # True/False are slips (a mask?), not signs, though Python counts True as 1
        arr = None if any(isinstance(v, (bool, np.bool_)) for v in values) else np.asarray(values, dtype=float)
    except (TypeError, ValueError, OverflowError):
        arr = None
    if arr is None or arr.shape != (count,) or not np.all(np.isin(arr, (1, -1))):
        many = "three" if count == 3 else count
        raise InvalidParameterError(f"{name} must be {many} signs such as (1, -1, 1) or '+-+', got {shown(mode)}")
    return arr.astype(np.int64)


#: The largest magnitude of a physical quantity of a machine (m, kg, kg·m², a gear ratio...): far beyond any machine,
#: and far enough below the float range that products of a few of them cannot overflow.
MAX_MAGNITUDE = 1e9


def as_real(name: str, value, sign: str = "", bounded: bool = False) -> float:
    """A scalar option as a finite float, ``sign`` ``"positive"`` or ``"non-negative"`` when required, and at most
    :data:`MAX_MAGNITUDE` in magnitude when ``bounded`` (a machine's physical quantity, not a gain).

    Bools, strings and arrays are refused, not converted: ``True`` or ``"0.1"`` are slips, not numbers.
    """
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    v = math.nan
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        try:
            v = float(value)
        except OverflowError:  # an int beyond the float range
            v = math.inf
    if not math.isfinite(v) or (sign == "positive" and v <= 0) or (sign == "non-negative" and v < 0):
        raise InvalidParameterError(f"{name} must be a {sign or 'finite'} number, got {shown(value)}")
    if bounded and abs(v) > MAX_MAGNITUDE:
        raise InvalidParameterError(f"{name} = {v:g} is beyond any machine: at most {MAX_MAGNITUDE:g} in magnitude "
                                    "(SI units)")
    return v


def as_count(name: str, value, low: int = 1, high: int | None = None) -> int:
    """An integer option within ``[low, high]`` (bools refused)."""
    ok = isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))
    if not ok or value < low or (high is not None and value > high):
        limits = f"at least {low}" if high is None else f"from {low} to {high}"
        raise InvalidParameterError(f"{name} must be an integer {limits}, got {shown(value)}")
    return int(value)


def as_choice(name: str, value, choices: tuple[str, ...]) -> str:
    """A string option among ``choices`` (an array or a dict is refused, not compared elementwise)."""
    if not isinstance(value, str) or value not in choices:
        raise InvalidParameterError(f"{name} must be {' or '.join(map(repr, choices))}, got {shown(value)}")
    return value


def as_flag(name: str, value) -> bool:
    """A yes/no option: ``True`` or ``False`` only (``1`` or ``"yes"`` are slips, not flags)."""
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidParameterError(f"{name} must be True or False, got {shown(value)}")
    return bool(value)


def as_limits(name: str, value, n: int, per: str = "actuator") -> np.ndarray | None:
    """A limit per actuator (``n``,) (or per ``per``): one positive number for all, or ``n`` of them; None stays
    None."""
    if value is None:
        return None
    wrong = InvalidParameterError(f"{name} must be a positive number or {n}, one per {per}, got {shown(value, 50)}")
    try:
        v = real_array(name, value)
    except InvalidParameterError:
        raise wrong from None
    if v.ndim == 0:
        v = np.full(n, float(v))
    if v.shape != (n,) or v.dtype.kind == "b" or not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise wrong
    return v


def shape_of(value) -> tuple[int, ...] | None:
    """The array shape of ``value``, or None for a ragged one (whose error :func:`as_batch` then names)."""
    try:
        return np.shape(value)
    except ValueError:
        return None
