"""The checks every JSON record off the bus (events, final reports) applies to one field: each raises ValueError
for a value that is not what the field must be, and the record's decoder turns that into "malformed"."""

from __future__ import annotations


def integer(v, lo: int, hi: int) -> int:
    """An int in [lo, hi]; JSON's true/false are not integers here, though Python's bool is one."""
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        raise ValueError
    return v


def number(v, lo: float, hi: float) -> float:
    """A number in [lo, hi]; NaN fails the comparison, so finite bounds also refuse NaN and ±inf."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
        raise ValueError
    return float(v)
