"""Shared helpers of the tests: the `holosym` command (HOLOSYM_EXE) and its real64 build
(HOLOSYM_EXE64), both set by `make python-test`, and the number format of their CSV."""

import csv
import io
import os
import subprocess
from decimal import Decimal

import pytest

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
MODELS = os.path.join(REPO, "example", "models")


@pytest.fixture(scope="session")
def holosym_exe():
    """Path of the holosym command (HOLOSYM_EXE); the tests that compare with it are
    skipped without it (`make python-test` always sets it)."""
    exe = os.environ.get("HOLOSYM_EXE")
    if not exe:
        pytest.skip("HOLOSYM_EXE is not set (make python-test sets it)")
    return exe


@pytest.fixture(scope="session")
def holosym_exe64():
    """Path of the holosym command of the real64 build (HOLOSYM_EXE64), for the
    comparisons of precision="double"; skipped without it."""
    exe = os.environ.get("HOLOSYM_EXE64")
    if not exe:
        pytest.skip("HOLOSYM_EXE64 is not set (make python-test sets it)")
    return exe


def run_cli(exe, *args):
    """The rows of `holosym simulate ARGS` as lists of strings, with the header."""
    done = subprocess.run([exe, "simulate", *args], capture_output=True, text=True,
                          check=True)
    rows = list(csv.reader(io.StringIO(done.stdout)))
    return rows[0], rows[1:]


def csv_real(value):
    """A Decimal as `holosym simulate` writes a real (Fortran es44.35e4: 36 significant
    digits, round-half-even, a signed four-digit exponent)."""
    if value.is_zero():
        return ("-" if value.is_signed() else "") + "0." + "0" * 35 + "E+0000"
    text = format(value, ".35E")
    mantissa, exponent = text.split("E")
    return f"{mantissa}E{int(exponent):+05d}"
