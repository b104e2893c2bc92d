"""IEEE 754 binary128 (``__float128``, real128) in pure Python.

ctypes has no 128-bit float, so holosym's reals cross the C interface as 16-byte buffers
(little-endian bit patterns on x86-64). This module converts those bit patterns exactly:

* :func:`to_fraction` and :func:`to_decimal` give the value exactly (a binary128 number is
  ``m * 2**e``; with ``e < 0`` it is ``m * 5**-e / 10**-e``, a decimal of finitely many
  digits, every one of them kept);
* :func:`to_float` rounds to the nearest float64 (round-half-even);
* :func:`from_value` rounds a str, Decimal, Fraction, int or float to the nearest binary128
  (round-half-even, with subnormals, overflow to infinity, signed zero, inf and nan).

The arithmetic is on Python integers and :class:`fractions.Fraction`, never on floats, so
every result is correctly rounded.
"""

from decimal import (Context, Decimal, Inexact, InvalidOperation, MAX_EMAX, MIN_EMIN,
                     ROUND_HALF_EVEN, Rounded)
from fractions import Fraction
import math
import re
import struct

__all__ = ["to_fraction", "to_decimal", "to_float", "from_value", "parse_value",
           "BYTES", "MAX", "MIN_SUBNORMAL", "MIN_NORMAL"]

#: Bytes of one binary128 value.
BYTES = 16
_FRACTION_BITS = 112
_EXPONENT_BITS = 15
_BIAS = 16383
_EMAX = 16383
_EMIN = 1 - _BIAS  # -16382, the exponent of the smallest normal number
_SIGN = 1 << 127
_EXP_MASK = ((1 << _EXPONENT_BITS) - 1) << _FRACTION_BITS
_FRAC_MASK = (1 << _FRACTION_BITS) - 1
_HIDDEN = 1 << _FRACTION_BITS
_QUIET_NAN = _EXP_MASK | (1 << (_FRACTION_BITS - 1))

#: The largest finite binary128 value, (2 - 2**-112) * 2**16383, exactly.
MAX = Fraction((2 * _HIDDEN - 1) * 2 ** (_EMAX - _FRACTION_BITS))
#: The smallest positive (subnormal) binary128 value, 2**-16494.
MIN_SUBNORMAL = Fraction(1, 2 ** (_FRACTION_BITS - _EMIN))
#: The smallest positive normal binary128 value, 2**-16382.
MIN_NORMAL = Fraction(1, 2 ** -_EMIN)


def _bits(raw):
    """The 128-bit integer of a 16-byte little-endian buffer."""
    if len(raw) != BYTES:
        raise ValueError(f"a binary128 value is 16 bytes, got {len(raw)}")
    return int.from_bytes(bytes(raw), "little")


def _decode(raw):
    """(sign, kind, m, e) of a buffer: kind 'finite' (value (-1)**sign * m * 2**e),
    'inf' or 'nan'."""
    bits = _bits(raw)
    sign = bits >> 127
    biased = (bits & _EXP_MASK) >> _FRACTION_BITS
    fraction = bits & _FRAC_MASK
    if biased == (1 << _EXPONENT_BITS) - 1:
        return sign, ("nan" if fraction else "inf"), 0, 0
    if biased == 0:  # zero or subnormal
        return sign, "finite", fraction, _EMIN - _FRACTION_BITS
    return sign, "finite", fraction | _HIDDEN, biased - _BIAS - _FRACTION_BITS


def to_fraction(raw):
    """The exact value of a binary128 buffer as a Fraction (ValueError for inf and nan;
    negative zero gives 0)."""
    sign, kind, m, e = _decode(raw)
    if kind != "finite":
        raise ValueError(f"binary128 {kind} has no Fraction value")
    value = Fraction(m * 2 ** e) if e >= 0 else Fraction(m, 2 ** -e)
    return -value if sign else value


def to_decimal(raw):
    """The exact value of a binary128 buffer as a Decimal, every digit (Decimal('-0') for
    negative zero, Decimal('Infinity'), Decimal('NaN')). No context rounding is involved:
    the Decimal is built from its digit string."""
    sign, kind, m, e = _decode(raw)
    minus = "-" if sign else ""
    if kind == "nan":
        return Decimal("NaN")
    if kind == "inf":
        return Decimal(minus + "Infinity")
    if m == 0:
        return Decimal(minus + "0")
    # m * 2**e; with e < 0 it is m * 5**k / 10**k (k = -e), a decimal of k places. Strip
    # the factors of two first so that the digits are no more than needed, then compute in
    # a context wide enough to be exact (Inexact and Rounded trap, so an inexact result
    # cannot pass unnoticed).
    shift = (m & -m).bit_length() - 1
    m >>= shift
    e += shift
    base, power = (Decimal(2), e) if e >= 0 else (Decimal(5), -e)
    digits = m.bit_length() * 0.302 + power * (0.302 if e >= 0 else 0.699) + 10
    context = Context(prec=int(digits), rounding=ROUND_HALF_EVEN, Emax=MAX_EMAX,
                      Emin=MIN_EMIN, traps=[Inexact, Rounded, InvalidOperation])
    value = context.multiply(Decimal(m), context.power(base, power))
    if e < 0:
        value = context.scaleb(value, e)
    return value.copy_negate() if sign else value


def to_float(raw):
    """The binary128 value of a buffer rounded to the nearest float64 (round-half-even;
    overflow gives +-inf, inf and nan stay)."""
    sign, kind, m, e = _decode(raw)
    if kind == "nan":
        return math.nan
    if kind == "inf":
        return -math.inf if sign else math.inf
    if m == 0:
        return -0.0 if sign else 0.0
    top = m.bit_length() + e  # 2**(top-1) <= |x| < 2**top
    if top > 1024:
        value = math.inf
    elif top >= -1021:
        # A normal float64 result: float(m) rounds once to 53 bits, ldexp is then exact...
        # except that rounding m to 53 bits first and scaling is exactly rounding x, since
        # scaling by a power of two commutes with rounding in the normal range.
        try:
            value = math.ldexp(float(m), e)
        except OverflowError:
            value = math.inf
    else:
        # Subnormal float64 range: int / int true division is correctly rounded.
        value = m / (1 << -e) if e < 0 else float(m << e)
    return -value if sign else value


def _encode(sign, biased, fraction):
    """The 16-byte buffer of sign, biased exponent and fraction field."""
    bits = (sign << 127) | (biased << _FRACTION_BITS) | fraction
    return bits.to_bytes(BYTES, "little")


def _round_fraction(x):
    """The buffer of the binary128 nearest the Fraction x >= 0 (round-half-even)."""
    if x == 0:
        return _encode(0, 0, 0)
    a, b = x.numerator, x.denominator
    e = a.bit_length() - b.bit_length()  # 2**(e-1) < x < 2**(e+1)
    if (a << max(0, -e)) < (b << max(0, e)):  # x < 2**e
        e -= 1
    # Now 2**e <= x < 2**(e+1). Quantum of the result: 2**(e - 112), or the subnormal
    # quantum 2**(EMIN - 112) below the normal range.
    quantum = max(e, _EMIN) - _FRACTION_BITS
    num = a << max(0, -quantum)
    den = b << max(0, quantum)
    n, r = divmod(num, den)
    if 2 * r > den or (2 * r == den and n & 1):
        n += 1
    if n == 2 * _HIDDEN:  # rounded up to the next power of two
        n = _HIDDEN
        quantum += 1
    if n < _HIDDEN:  # subnormal (quantum is the subnormal one)
        return _encode(0, 0, n)
    biased = quantum + _FRACTION_BITS + _BIAS
    if biased >= (1 << _EXPONENT_BITS) - 1:
        return _encode(0, (1 << _EXPONENT_BITS) - 1, 0)  # overflow: infinity
    return _encode(0, biased, n - _HIDDEN)


_SPECIAL = re.compile(r"^\s*([+-]?)(inf|infinity|nan)\s*$", re.IGNORECASE)


def parse_value(value):
    """(negative, Fraction or 'inf' or 'nan') of a str, Decimal, Fraction, int or float,
    exactly. Strings: a decimal number ("0.1", "-2.5e-3"), a quotient ("1/160",
    "-3/7"), "inf", "-inf" or "nan". TypeError or ValueError for anything else."""
    if isinstance(value, bool):
        raise TypeError("a real number is expected, got a bool")
    if isinstance(value, str):
        special = _SPECIAL.match(value)
        if special:
            word = special.group(2).lower()
            return special.group(1) == "-", ("nan" if word == "nan" else "inf")
        text = value.strip()
        if "/" in text:
            num, _, den = text.partition("/")
            top, bottom = parse_value(num), parse_value(den)
            for part in (top, bottom):
                if not isinstance(part[1], Fraction):
                    raise ValueError(f"not a number: {value!r}")
            if bottom[1] == 0:
                raise ValueError(f"division by zero in {value!r}")
            negative = top[0] != bottom[0]
            return negative, top[1] / bottom[1]
        try:
            value = Decimal(text)
        except Exception:
            raise ValueError(f"not a number: {value!r}") from None
    if isinstance(value, Decimal):
        if value.is_nan():
            return False, "nan"
        negative = value.is_signed()
        if value.is_infinite():
            return negative, "inf"
        return negative, abs(Fraction(value))
    if isinstance(value, float):
        if math.isnan(value):
            return False, "nan"
        negative = math.copysign(1.0, value) < 0
        if math.isinf(value):
            return negative, "inf"
        return negative, abs(Fraction(value))
    if isinstance(value, (int, Fraction)):
        return value < 0, abs(Fraction(value))
    # numpy scalars and other numbers: through their exact float or int value
    if hasattr(value, "__float__") and not hasattr(value, "__index__"):
        return parse_value(float(value))
    if hasattr(value, "__index__"):
        return parse_value(int(value.__index__()))
    raise TypeError(f"a real number (str, Decimal, Fraction, int or float) is expected, "
                    f"got {type(value).__name__}")


def from_value(value):
    """The 16-byte buffer of the binary128 nearest `value` (str, Decimal, Fraction, int or
    float; round-half-even). Exact inputs stay exact: "1/160" and Fraction(1, 160) give
    the binary128 nearest 1/160, not the one nearest the float 1/160."""
    negative, x = parse_value(value)
    if x == "nan":
        raw = _QUIET_NAN.to_bytes(BYTES, "little")
    elif x == "inf":
        raw = _encode(0, (1 << _EXPONENT_BITS) - 1, 0)
    else:
        raw = _round_fraction(x)
    if negative:
        raw = (_bits(raw) | _SIGN).to_bytes(BYTES, "little")
    return raw
