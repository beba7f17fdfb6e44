"""The exceptions splitlf raises.

Every error that bad input can cause derives from :class:`SplitlfError`, and also from the
built-in exception a caller would expect, so ``except ValueError`` keeps working:

- :class:`InvalidParameter` (``ValueError``): a parameter, or one element of an array
  parameter, is outside its allowed range. It carries the parameter's ``name``, the
  offending ``value``, a description of what is ``allowed`` and, for arrays, the ``index``.
- :class:`TooLargeError` (``MemoryError``): the requested outputs (or the work) would not
  fit in this machine's memory or in the stated limits; raised before the work starts, or
  when an allocation fails.

Faults of splitlf itself (an internal invariant broken) are ``RuntimeError`` and are never
disguised as bad input.
"""

from __future__ import annotations

from typing import Any

__all__ = ["InvalidParameter", "SplitlfError", "TooLargeError"]


class SplitlfError(Exception):
    """Base class of the errors splitlf raises for input it cannot process."""


class InvalidParameter(SplitlfError, ValueError):
    """A parameter outside its allowed range.

    Attributes: ``name`` (the parameter, e.g. ``"z"`` or ``"Q"``), ``value`` (what was
    given; for an array the offending element), ``allowed`` (the allowed range, in words),
    ``index`` (the element's position for array parameters, else ``None``).
    """

    def __init__(self, message: str, *, name: str, value: Any = None, allowed: str = "",
                 index: int | None = None) -> None:
        super().__init__(message)
        self.name = name
        self.value = value
        self.allowed = allowed
        self.index = index

    @classmethod
    def of(cls, name: str, value: Any, allowed: str, index: int | None = None
           ) -> InvalidParameter:
        """The standard message: ``invalid NAME = VALUE: allowed ALLOWED``."""
        where = name if index is None else f"{name}[{index}]"
        return cls(f"invalid {where} = {value!r}: allowed {allowed}", name=name, value=value,
                   allowed=allowed, index=index)

    def __reduce__(self) -> Any:
        return (_rebuild_invalid, (str(self), self.name, self.value, self.allowed, self.index))


def _rebuild_invalid(message: str, name: str, value: Any, allowed: str,
                     index: int | None) -> InvalidParameter:
    return InvalidParameter(message, name=name, value=value, allowed=allowed, index=index)


class TooLargeError(SplitlfError, MemoryError):
    """The requested outputs or work would not fit in memory or exceed a stated limit.

    Attributes: ``what`` (the call and the buffer), ``bytes`` (the size needed, or ``None``
    when the limit is not in bytes), ``limit``.
    """

    def __init__(self, message: str, *, what: str = "", nbytes: int | None = None,
                 limit: int | None = None) -> None:
        super().__init__(message)
        self.what = what
        self.bytes = nbytes
        self.limit = limit

    def __reduce__(self) -> Any:
        return (_rebuild_too_large, (str(self), self.what, self.bytes, self.limit))


def _rebuild_too_large(message: str, what: str, nbytes: int | None,
                       limit: int | None) -> TooLargeError:
    return TooLargeError(message, what=what, nbytes=nbytes, limit=limit)
