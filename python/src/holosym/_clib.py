"""The C interface of holosym (include/holosym.h) through ctypes, for both libraries of
the package.

precision="quad" is the package's libholosym.so (the real128 build: holosym_real is
__float128) and precision="double" its libholosym64.so (the real64 build,
-DHOLOSYM_REAL64: holosym_real is double), both built by pip install with the project's
CMake; the environment variables HOLOSYM_LIBRARY and HOLOSYM_LIBRARY64 name other files.
The two export the same symbol names: each is loaded with RTLD_LOCAL (its symbols stay out
of the process's global scope) and is linked with -Bsymbolic (its own calls bind to its
own code), so each keeps its own Fortran module data, e.g. its registry of live handles; a
handle of one is refused by the other. They share the process's gfortran and OpenMP
run-time libraries, which hold no state of holosym.

Only calls without a real passed by value are declared: every real scalar crosses through
a pointer (the _p functions of the header), since ctypes has no __float128; the real64
library is driven through the same calls, with 8-byte reals.
"""

import ctypes
import os

from . import _binary128, _binary64

_here = os.path.dirname(os.path.abspath(__file__))

#: The precisions and, for each, the environment variable that overrides the library's
#: path, the library's file in the package, its build and the conversions of its reals.
PRECISIONS = {
    "quad": ("HOLOSYM_LIBRARY", "libholosym.so", "real128", _binary128),
    "double": ("HOLOSYM_LIBRARY64", "libholosym64.so", "real64", _binary64),
}

_p = ctypes.c_void_p
_int = ctypes.c_int
_int_p = ctypes.POINTER(ctypes.c_int)

#: The observer of holosym_integrate_p: (handle, step, const real *t, q, p, data) -> int.
OBSERVER = ctypes.CFUNCTYPE(_int, _p, _int, _p, _p, _p, _p)

#: An event function of holosym_integrate_events: (k, const real *t, q, p, real *value,
#: data) -> int.
EVENT_FUNCTION = ctypes.CFUNCTYPE(_int, _int, _p, _p, _p, _p, _p)
#: Receives a located event: (k, direction, const real *t, q, p, lambda, data) -> int.
EVENT_FOUND = ctypes.CFUNCTYPE(_int, _int, _int, _p, _p, _p, _p, _p)

NAME_PARAMETER, NAME_COORDINATE, NAME_MOMENTUM = 0, 1, 2


def library_path(precision):
    """Path of the library of a precision ("quad" or "double")."""
    variable, file_name, _, _ = PRECISIONS[precision]
    return os.environ.get(variable) or os.path.join(_here, file_name)


class Library:
    """One loaded library: its C functions as attributes, `codec` the module converting
    its reals (_binary128 or _binary64) and `bytes` the size of one real."""

    def __init__(self, precision):
        variable, _, build, codec = PRECISIONS[precision]
        self.precision = precision
        self.path = library_path(precision)
        self.codec = codec
        self.bytes = codec.BYTES
        try:
            self.lib = ctypes.CDLL(self.path, mode=ctypes.RTLD_LOCAL)
        except OSError as error:
            raise OSError(f"holosym: cannot load the library {self.path}: {error}. "
                          f"Reinstall the package (pip install ./python) or set "
                          f"{variable} to a library of the {build} build.") from None
        declare = self._declare
        self.model_create = declare("holosym_model_create", _p, ctypes.c_char_p, _int,
                                    _int, _int)
        self.destroy = declare("holosym_destroy", None, _p)
        self.status = declare("holosym_status", _int, _p)
        self.message = declare("holosym_message", _int, _p, _p, _int)
        self.sizes = declare("holosym_sizes", _int, _p, _int_p, _int_p)
        self.parameter_count = declare("holosym_model_parameter_count", _int, _p)
        self.model_name = declare("holosym_model_name", _int, _p, _int, _int, _p, _int)
        self.get_parameter = declare("holosym_model_get_parameter", _int, _p,
                                     ctypes.c_char_p, _p)
        self.set_parameter_p = declare("holosym_model_set_parameter_p", _int, _p,
                                       ctypes.c_char_p, _p)
        self.initial_state = declare("holosym_model_initial_state", _int, _p, _p, _p)
        self.step_p = declare("holosym_step_p", _int, _p, _p, _p, _p)
        self.integrate_p = declare("holosym_integrate_p", _int, _p, _p, _p, _p, _int, _p,
                                   _p, _int_p)
        self.dense_output_p = declare("holosym_dense_output_p", _int, _p, _p, _p, _p, _p)
        self.project = declare("holosym_project", _int, _p, _p, _p)
        self.energy = declare("holosym_energy", _int, _p, _p, _p, _p)
        self.constraint = declare("holosym_constraint", _int, _p, _p, _p)
        self.plan_accuracy = declare("holosym_plan_accuracy", _int, _p, _p, _p, _p, _p,
                                     _p, _int_p, _p)
        self.integrate_events = declare("holosym_integrate_events", _int, _p, _p, _p, _p,
                                        _int, _int, _p, _p, _p, _p, _p, _int_p, _int_p)
        self.lyapunov_spectrum = declare("holosym_lyapunov_spectrum", _int, _p, _p, _p, _p,
                                         _int, _p, _p, _int_p)
        self.step_tangent = declare("holosym_step_tangent", _int, _p, _p, _p, _p, _int, _p,
                                    _p)
        self.tangent_basis = declare("holosym_tangent_basis", _int, _p, _p, _p, _p, _p,
                                     _int_p)
        self.project_tangent = declare("holosym_project_tangent", _int, _p, _p, _p, _int, _p,
                                       _p)

    def _declare(self, name, restype, *argtypes):
        function = getattr(self.lib, name)
        function.restype = restype
        function.argtypes = list(argtypes)
        return function

    def message_of(self, handle):
        """The message of the handle's last call (str)."""
        length = self.message(handle, None, 0)
        buffer = ctypes.create_string_buffer(length + 1)
        self.message(handle, buffer, length + 1)
        return buffer.value.decode("utf-8", "replace")

    def reals(self, count, raw=None):
        """A buffer of `count` reals of this library (see Reals)."""
        return Reals(count, raw, self.bytes)

    def split(self, raw):
        """The pieces (one real each) of a buffer of this library's reals."""
        size = self.bytes
        return [raw[i:i + size] for i in range(0, len(raw), size)]

    def __repr__(self):
        return f"<holosym library {self.precision} {self.path}>"


_loaded = {}


def library(precision):
    """The Library of a precision, loaded on first use (OSError if it cannot be)."""
    if precision not in _loaded:
        _loaded[precision] = Library(precision)
    return _loaded[precision]


class Reals:
    """A buffer of `count` reals of `size` bytes each, 16-byte aligned (as __float128
    must be), in memory owned by Python. `address` is what the C functions receive."""

    def __init__(self, count, raw=None, size=_binary128.BYTES):
        self.count = count
        self.size = size
        self._storage = (ctypes.c_uint8 * (size * max(count, 1) + 16))()
        base = ctypes.addressof(self._storage)
        self.address = base + (-base) % 16
        if raw is not None:
            self.set_bytes(raw)

    def get_bytes(self):
        """The buffer's size * count bytes."""
        return ctypes.string_at(self.address, self.size * self.count)

    def set_bytes(self, raw):
        """Fill the buffer with size * count bytes."""
        raw = bytes(raw)
        if len(raw) != self.size * self.count:
            raise ValueError(f"{len(raw)} bytes for {self.count} reals of {self.size} "
                             f"bytes")
        ctypes.memmove(self.address, raw, len(raw))


try:
    #: The real128 library, loaded with the package.
    QUAD = library("quad")
except OSError as error:  # pragma: no cover - a broken installation
    raise ImportError(str(error)) from None
#: Path of the real128 library in use.
LIBRARY_PATH = QUAD.path
