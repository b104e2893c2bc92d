"""The binary128 conversions: exact Decimals, nearest binary128 (round-half-even),
float64, on the edge cases (1, 1/3, the largest, the smallest subnormal, signed zero,
ties, overflow, inf, nan)."""

from decimal import Decimal
from fractions import Fraction
import math
import random

import pytest

from holosym import binary128 as b


def bits(value):
    return int.from_bytes(b.from_value(value), "little")


def from_bits(pattern):
    return pattern.to_bytes(16, "little")


def ulp(x):
    """The spacing of binary128 numbers at the Fraction x > 0 (normal range)."""
    e = x.numerator.bit_length() - x.denominator.bit_length()
    if Fraction(2) ** e > x:
        e -= 1
    return Fraction(2) ** (e - 112)


def test_one():
    assert bits(1) == 0x3FFF << 112
    assert b.to_decimal(b.from_value("1")) == 1
    assert str(b.to_decimal(b.from_value(1.0))) == "1"
    assert b.to_float(b.from_value(Decimal("1.0"))) == 1.0


def test_one_third_is_the_nearest_and_exact():
    raw = b.from_value("1/3")
    assert int.from_bytes(raw, "little") == 0x3FFD5555555555555555555555555555
    x = b.to_fraction(raw)
    assert abs(x - Fraction(1, 3)) <= ulp(Fraction(1, 3)) / 2
    d = b.to_decimal(raw)
    assert Fraction(d) == x  # every digit: the Decimal is the binary value exactly
    # the expansion by integer arithmetic: m / 2**114 = m * 5**114 / 10**114
    m = 0x15555555555555555555555555555
    assert x == Fraction(m, 2 ** 114)
    digits = str(m * 5 ** 114).rjust(115, "0")
    assert str(d) == "0." + digits[-114:].rstrip("0")
    assert b.from_value(d) == raw  # and reads back to the same bits
    assert b.from_value(Fraction(1, 3)) == raw == b.from_value(" 1 / 3 ")


def test_largest_finite():
    raw = from_bits(0x7FFEFFFFFFFFFFFFFFFFFFFFFFFFFFFF)
    assert b.to_fraction(raw) == b.MAX == (2 ** 113 - 1) * Fraction(2) ** (16383 - 112)
    d = b.to_decimal(raw)
    assert Fraction(d) == b.MAX
    assert f"{d:.35E}" == "1.18973149535723176508575932662800702E+4932"  # FLT128_MAX
    assert b.from_value(d) == raw
    assert b.to_float(raw) == math.inf


def test_overflow_rounds_to_infinity_at_half_an_ulp():
    half = Fraction(2) ** (16383 - 113)  # half the spacing at MAX
    assert bits(b.MAX + half) == 0x7FFF << 112  # tie, MAX odd: up to infinity
    assert bits(b.MAX + half - Fraction(1, 10 ** 5000)) == 0x7FFEFFFFFFFFFFFFFFFFFFFFFFFFFFFF
    assert bits("1e5000") == 0x7FFF << 112
    assert bits("-1e5000") == 0xFFFF << 112


def test_smallest_subnormal():
    raw = from_bits(1)
    assert b.to_fraction(raw) == b.MIN_SUBNORMAL == Fraction(1, 2 ** 16494)
    d = b.to_decimal(raw)
    assert Fraction(d) == b.MIN_SUBNORMAL
    assert f"{d:.35E}" == "6.47517511943802511092443895822764655E-4966"  # FLT128_DENORM_MIN
    # every digit of 5**16494 / 10**16494: floor(16494 log10 5) + 1 of them
    assert len(d.as_tuple().digits) == math.floor(16494 * math.log10(5)) + 1 == 11529
    assert d.as_tuple().exponent == -16494
    assert b.from_value(d) == raw
    assert b.to_float(raw) == 0.0


def test_subnormal_ties_and_the_normal_boundary():
    s = b.MIN_SUBNORMAL
    assert bits(s / 2) == 0  # tie between 0 and s: to even (0)
    assert bits(s / 2 + s / 1000) == 1
    assert bits(3 * s / 2) == 2  # tie between s and 2s: to even (2s)
    assert bits(5 * s / 2) == 2
    assert bits(b.MIN_NORMAL) == 1 << 112
    assert bits(b.MIN_NORMAL - s) == (1 << 112) - 1  # the largest subnormal
    assert bits(b.MIN_NORMAL - s / 2) == 1 << 112  # tie: to even, the smallest normal


def test_ties_round_half_even():
    e = Fraction(1, 2 ** 112)  # spacing at 1
    assert bits(1 + e / 2) == 0x3FFF << 112  # tie: 1 (even)
    assert bits(1 + 3 * e / 2) == (0x3FFF << 112) + 2  # tie: 1 + 2e (even)
    assert bits(1 + e / 2 + Fraction(1, 2 ** 200)) == (0x3FFF << 112) + 1
    # a decimal string that is exactly a tie
    tie = b.to_decimal(b.from_value(1)) + Decimal(2) ** -113
    assert bits(str(tie)) == 0x3FFF << 112
    assert bits("-" + str(tie)) == 0xBFFF << 112


def test_signed_zero_inf_nan():
    for value in ("-0", "-0.0", -0.0, Decimal("-0"), Decimal("-0E+5")):
        assert bits(value) == 1 << 127
        assert str(b.to_decimal(b.from_value(value))) == "-0"
        assert math.copysign(1.0, b.to_float(b.from_value(value))) == -1.0
    for value in ("0", 0, 0.0, Fraction(0), Decimal("0.000")):
        assert bits(value) == 0
    assert b.to_decimal(b.from_value("inf")) == Decimal("Infinity")
    assert b.to_decimal(b.from_value("-Infinity")) == Decimal("-Infinity")
    assert b.to_float(b.from_value(-math.inf)) == -math.inf
    assert b.to_decimal(b.from_value("nan")).is_nan()
    assert math.isnan(b.to_float(b.from_value(math.nan)))
    with pytest.raises(ValueError):
        b.to_fraction(b.from_value("inf"))


def test_exact_inputs_stay_exact():
    assert b.from_value("1/160") == b.from_value(Fraction(1, 160)) == \
        b.from_value(Decimal("0.00625")) == b.from_value("6.25e-3")
    # the float 1/160 is another number, taken at its exact binary value
    assert b.from_value(1 / 160) != b.from_value("1/160")
    assert b.to_fraction(b.from_value(1 / 160)) == Fraction(1 / 160)
    assert b.to_fraction(b.from_value(2 ** 70 + 1)) == 2 ** 70 + 1
    assert b.from_value("0.1") != b.from_value(0.1)


def test_float64_round_trip_and_rounding():
    rng = random.Random(5)
    for _ in range(2000):
        x = rng.uniform(-1, 1) * 10.0 ** rng.randint(-300, 300)
        assert b.to_float(b.from_value(x)) == x
    for x in (5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, -4e-320):
        assert b.to_float(b.from_value(x)) == x
    # binary128 values between float64s round to the nearest float64, ties to even
    one_and_half_ulp = Fraction(1) + Fraction(1, 2 ** 53)
    assert b.to_float(b.from_value(one_and_half_ulp)) == 1.0
    assert b.to_float(b.from_value(one_and_half_ulp + Fraction(1, 2 ** 100))) == \
        1.0 + 2.0 ** -52
    # in the float64 subnormal range as well
    assert b.to_float(b.from_value(Fraction(3, 2) * Fraction(1, 2 ** 1074))) == 1e-323


def test_bad_inputs():
    for value in ("abc", "1/0", "", "1/x"):
        with pytest.raises(ValueError):
            b.from_value(value)
    for value in (None, [1], True, 1j):
        with pytest.raises(TypeError):
            b.from_value(value)
