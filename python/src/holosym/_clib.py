"""The C interface of holosym (include/holosym.h) through ctypes.

The shared library is the package's own libholosym.so (built by pip install with the
project's CMake), or the file named by the environment variable HOLOSYM_LIBRARY. Only
calls without a real passed by value are declared: every real scalar crosses through a
pointer (the _p functions of the header), since ctypes has no __float128.
"""

import ctypes
import os

from . import _binary128

_here = os.path.dirname(os.path.abspath(__file__))
#: Path of the shared library in use.
LIBRARY_PATH = os.environ.get("HOLOSYM_LIBRARY") or os.path.join(_here, "libholosym.so")

try:
    lib = ctypes.CDLL(LIBRARY_PATH)
except OSError as error:  # pragma: no cover - a broken installation
    raise ImportError(f"holosym: cannot load the library {LIBRARY_PATH}: {error}. "
                      f"Reinstall the package (pip install ./python) or set "
                      f"HOLOSYM_LIBRARY to a libholosym.so of the real128 build.") from None

_p = ctypes.c_void_p
_int = ctypes.c_int
_int_p = ctypes.POINTER(ctypes.c_int)

#: The observer of holosym_integrate_p: (handle, step, const real *t, q, p, data) -> int.
OBSERVER = ctypes.CFUNCTYPE(_int, _p, _int, _p, _p, _p, _p)


def _declare(name, restype, *argtypes):
    function = getattr(lib, name)
    function.restype = restype
    function.argtypes = list(argtypes)
    return function


model_create = _declare("holosym_model_create", _p, ctypes.c_char_p, _int, _int, _int)
destroy = _declare("holosym_destroy", None, _p)
status = _declare("holosym_status", _int, _p)
message = _declare("holosym_message", _int, _p, _p, _int)
sizes = _declare("holosym_sizes", _int, _p, _int_p, _int_p)
parameter_count = _declare("holosym_model_parameter_count", _int, _p)
model_name = _declare("holosym_model_name", _int, _p, _int, _int, _p, _int)
get_parameter = _declare("holosym_model_get_parameter", _int, _p, ctypes.c_char_p, _p)
set_parameter_p = _declare("holosym_model_set_parameter_p", _int, _p, ctypes.c_char_p, _p)
initial_state = _declare("holosym_model_initial_state", _int, _p, _p, _p)
step_p = _declare("holosym_step_p", _int, _p, _p, _p, _p)
integrate_p = _declare("holosym_integrate_p", _int, _p, _p, _p, _p, _int, _p, _p, _int_p)
dense_output_p = _declare("holosym_dense_output_p", _int, _p, _p, _p, _p, _p)
project = _declare("holosym_project", _int, _p, _p, _p)
energy = _declare("holosym_energy", _int, _p, _p, _p, _p)
constraint = _declare("holosym_constraint", _int, _p, _p, _p)

NAME_PARAMETER, NAME_COORDINATE, NAME_MOMENTUM = 0, 1, 2


def message_of(handle):
    """The message of the handle's last call (str)."""
    length = message(handle, None, 0)
    buffer = ctypes.create_string_buffer(length + 1)
    message(handle, buffer, length + 1)
    return buffer.value.decode("utf-8", "replace")


class Reals:
    """A buffer of `count` binary128 values, 16-byte aligned (as __float128 must be), in
    memory owned by Python. `address` is what the C functions receive."""

    def __init__(self, count, raw=None):
        self.count = count
        self._storage = (ctypes.c_uint8 * (_binary128.BYTES * max(count, 1) + 16))()
        base = ctypes.addressof(self._storage)
        self.address = base + (-base) % 16
        if raw is not None:
            self.set_bytes(raw)

    def get_bytes(self):
        """The buffer's 16 * count bytes."""
        return ctypes.string_at(self.address, _binary128.BYTES * self.count)

    def set_bytes(self, raw):
        """Fill the buffer with 16 * count bytes."""
        raw = bytes(raw)
        if len(raw) != _binary128.BYTES * self.count:
            raise ValueError(f"{len(raw)} bytes for {self.count} binary128 values")
        ctypes.memmove(self.address, raw, len(raw))


def split(raw):
    """The 16-byte pieces of a buffer of binary128 values."""
    size = _binary128.BYTES
    return [raw[i:i + size] for i in range(0, len(raw), size)]
