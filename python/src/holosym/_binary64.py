"""IEEE 754 binary64 (``double``, real64) buffers: the counterpart of :mod:`_binary128`
for the real64 library (precision="double"), with the same functions.

A double crosses the C interface as 8 bytes (little-endian on x86-64). Going in, a str,
Decimal, Fraction, int or float is rounded once to the nearest double: the input is taken
exactly (a Fraction, through :func:`_binary128.parse_value`) and converted with Python's
``float(Fraction)``, which is correctly rounded (round-half-even, subnormals, overflow to
infinity). Coming out, a double is exactly a Fraction and a Decimal of finitely many
digits.
"""

from decimal import Decimal
from fractions import Fraction
import math
import struct

from ._binary128 import parse_value

__all__ = ["to_fraction", "to_decimal", "to_float", "from_value", "parse_value",
           "BYTES", "MAX", "MIN_SUBNORMAL", "MIN_NORMAL"]

#: Bytes of one binary64 value.
BYTES = 8
#: The largest finite double, exactly.
MAX = Fraction(2 ** 53 - 1) * 2 ** 971
#: The smallest positive (subnormal) double, 2**-1074.
MIN_SUBNORMAL = Fraction(1, 2 ** 1074)
#: The smallest positive normal double, 2**-1022.
MIN_NORMAL = Fraction(1, 2 ** 1022)

_FORMAT = "<d"


def to_float(raw):
    """The double of an 8-byte buffer."""
    if len(raw) != BYTES:
        raise ValueError(f"a binary64 value is 8 bytes, got {len(raw)}")
    return struct.unpack(_FORMAT, bytes(raw))[0]


def to_fraction(raw):
    """The exact value as a Fraction (ValueError for inf and nan; -0 gives 0)."""
    value = to_float(raw)
    if not math.isfinite(value):
        raise ValueError(f"binary64 {'nan' if math.isnan(value) else 'inf'} has no "
                         f"Fraction value")
    return Fraction(value)


def to_decimal(raw):
    """The exact value as a Decimal, every digit (Decimal('-0') for negative zero,
    Decimal('Infinity'), Decimal('NaN'))."""
    value = to_float(raw)
    if math.isnan(value):
        return Decimal("NaN")
    return Decimal(value)  # exact: Decimal of a float converts its binary value


def _nearest(x):
    """The double nearest the Fraction x >= 0 (round-half-even; inf beyond MAX + ulp/2)."""
    try:
        return float(x)  # Fraction.__float__: int / int, correctly rounded
    except OverflowError:
        return math.inf


def from_value(value):
    """The 8-byte buffer of the double nearest `value` (str, Decimal, Fraction, int or
    float; round-half-even, rounded once: "0.1" and Fraction(1, 10) give float 0.1)."""
    negative, x = parse_value(value)
    if x == "nan":
        result = math.nan
    elif x == "inf":
        result = math.inf
    else:
        result = _nearest(x)
    if negative:
        result = -result
    return struct.pack(_FORMAT, result)
