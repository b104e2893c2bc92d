"""holosym: high-order symplectic integration of Hamiltonian systems with holonomic
constraints, in real128 (IEEE binary128) or real64 (double), over the library's C
interface.

    import holosym
    model = holosym.Model.builtin("fourbar")      # or Model.from_file(path), Model(text)
    model.set(omega=3)                            # parameters by name
    run = holosym.simulate(model, M=8, h="1/160", T=20, every=160)
    run.t, run.q, run.p, run.energy_error, run.constraint_residual   # numpy float64
    q, p = run.exact(-1)                          # Decimals, every digit of real128
    fast = holosym.simulate(model, M=8, h="1/160", T=20, every=160, precision="double")

precision="quad" (the default of simulate, Integrator and ensemble) runs the real128
library, precision="double" the real64 one (the same library built with -DHOLOSYM_REAL64,
also in the package): faster, with the round-off of a double.

Reals going in (h, T, parameters, states) may be str ("1/160", "0.1"), Decimal, Fraction,
int or float; each is rounded once, to the nearest binary128 (or double, for
precision="double"), so "1/160" and Fraction(1, 160) lose no digit on the way (a float is
taken at its exact binary value). Reals coming out are numpy float64 arrays (rounded to
nearest) or, through the `exact` methods, Decimals with every digit of the binary128 (or
double) value.

Failures raise :class:`Error` with the library's status code (`.code`, the HOLOSYM_*
constants below) and message (`.message`); the state of an :class:`Integrator` is then
unchanged (integrate: the last good step).
"""

from decimal import Decimal
from fractions import Fraction
import os

import numpy as np

from . import _binary128 as binary128
from . import _binary64 as binary64
from . import _clib

try:
    from importlib.metadata import version as _version
    __version__ = _version("holosym")
except Exception:  # pragma: no cover - not installed as a distribution
    __version__ = "unknown"

__all__ = ["Error", "Model", "Integrator", "Event", "Run", "EnsembleResult", "simulate", "ensemble",
           "binary128", "binary64", "builtin_models", "PRECISIONS"]

#: The values of the `precision` argument: "quad" (real128, the default) and "double"
#: (real64).
PRECISIONS = ("quad", "double")

# Status codes (include/holosym.h).
SUCCESS = 0
INVALID_ORDER = -1
INVALID_DIMENSION = -2
SIZE_MISMATCH = -3
INVALID_STEP_SIZE = -4
INVALID_STEP_COUNT = -5
OFF_MANIFOLD = -6
USER_ABORT = -7
NOT_INITIALIZED = -8
INVALID_ARGUMENT = -9
INVALID_MODEL = -10
INCONSISTENT_SYSTEM = -11
SINGULAR_MATRIX = 1
NEWTON_NOT_CONVERGED = 2
NEWTON_DIVERGED = 3
NONFINITE_VALUE = 4
RANK_DEFICIENT_CONSTRAINTS = 5
STEP_TOO_LARGE = 6
STEP_TOO_SMALL = 7
OUTSIDE_DOMAIN = 8

_CODE_NAMES = {value: "HOLOSYM_" + name for name, value in globals().items()
               if name.isupper() and isinstance(value, int) and not name.startswith("_")}

# Directions of the crossings wanted from an event function (Integrator.integrate_events;
# HOLOSYM_EVENT_* in the header). Not status codes: defined after their table.
EVENT_ANY = 0
EVENT_RISING = 1
EVENT_FALLING = -1


class Error(Exception):
    """A failure of holosym: `code` is the library's status code (< 0 invalid input,
    > 0 numerical failure; the HOLOSYM_* values, also module constants such as
    holosym.INVALID_STEP_SIZE), `message` says what and where."""

    def __init__(self, code, message):
        self.code = int(code)
        self.message = message
        super().__init__(f"{message} [{_CODE_NAMES.get(self.code, 'code')} = {self.code}]")


def _check(code, handle):
    """Raise Error for a nonzero status code of a call on `handle` (a _Handle)."""
    if code != SUCCESS:
        raise Error(code, handle.lib.message_of(handle.pointer))


def _real_bytes(value, what, lib=_clib.QUAD):
    """The bytes of one real input rounded to the reals of `lib` (binary128 or double),
    Error(INVALID_ARGUMENT) naming `what`."""
    try:
        return lib.codec.from_value(value)
    except (TypeError, ValueError) as error:
        raise Error(INVALID_ARGUMENT, f"{what}: {error}") from None


def _vector_bytes(values, n, what, lib=_clib.QUAD):
    """The bytes of n real inputs (a sequence or numpy array) for `lib`."""
    values = list(np.asarray(values, dtype=object).ravel()) if isinstance(values, np.ndarray) \
        else list(values)
    if len(values) != n:
        raise Error(SIZE_MISMATCH, f"{what}: {n} values expected, got {len(values)}")
    return b"".join(_real_bytes(v, f"{what}[{i}]", lib) for i, v in enumerate(values))


def _decimals(raw, lib=_clib.QUAD):
    """Tuple of exact Decimals of a buffer of reals of `lib`."""
    return tuple(lib.codec.to_decimal(piece) for piece in lib.split(raw))


def _floats(raw, lib=_clib.QUAD):
    """float64 numpy array of a buffer of reals of `lib`."""
    return np.array([lib.codec.to_float(piece) for piece in lib.split(raw)], dtype=float)


def _library(precision):
    """The library of a precision: "quad" (real128) or "double" (real64); any other
    value is Error(INVALID_ARGUMENT) naming the allowed ones."""
    if not isinstance(precision, str) or precision not in PRECISIONS:
        raise Error(INVALID_ARGUMENT, f"precision={precision!r}: the precision is 'quad' "
                    f"(real128, the default) or 'double' (real64)")
    try:
        return _clib.library(precision)
    except OSError as error:
        raise Error(INVALID_ARGUMENT, f"precision={precision!r}: {error}") from None


# ---------------------------------------------------------------------------- models

_MODELS_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "models")
_ALIASES = {"pendulum": "spherical_pendulum"}


def builtin_models():
    """Names accepted by Model.builtin: the model files shipped with the package (copies
    of the repository's example/models/*.hsm) and the alias "pendulum" (the spherical
    pendulum)."""
    names = sorted(f[:-4] for f in os.listdir(_MODELS_DIR) if f.endswith(".hsm")) \
        if os.path.isdir(_MODELS_DIR) else []
    return sorted(names + [a for a, target in _ALIASES.items() if target in names])


class _Handle:
    """An owned C handle of the library `lib` (holosym_destroy when collected or
    closed)."""

    def __init__(self, pointer, lib):
        self.pointer = pointer
        self.lib = lib

    def close(self):
        if self.pointer:
            self.lib.destroy(self.pointer)
            self.pointer = None

    def __del__(self):
        try:
            self.close()
        except Exception:  # pragma: no cover - interpreter shutdown
            pass


def _create(text, M, N, G, label="model", lib=_clib.QUAD):
    """A handle of `lib` for a model text and (M, N, G); Error with the library's message
    (for a refused text "model:LINE:COLUMN: ...", `label` instead of "model")."""
    for name, value in (("M", M), ("N", N), ("G", G)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise Error(INVALID_ORDER, f"{name} must be an int, got {value!r}")
    pointer = lib.model_create(text.encode("utf-8"), int(M), int(N), int(G))
    handle = _Handle(pointer, lib)
    code = lib.status(pointer)
    if code != SUCCESS:
        message = lib.message_of(pointer)
        if label != "model" and message.startswith("model:"):
            message = label + message[len("model"):]
        handle.close()
        raise Error(code, message)
    return handle


class Model:
    """A constrained Hamiltonian system from the text of a model file (docs/models.md has
    the grammar): the library parses it and derives every derivative itself.

    Model(text) refuses a bad text with Error(INVALID_MODEL, "model:LINE:COLUMN: ...").
    Parameters are set by name (:meth:`set`) and apply to every integrator made from the
    model afterwards, each value rounded once to the integrator's precision. The model's
    own values (get, parameters, initial_state) are those of the real128 library."""

    def __init__(self, text, name=None):
        """The model of `text` (str); `name` labels it (and its error messages)."""
        if not isinstance(text, str):
            raise Error(INVALID_ARGUMENT, f"a model text (str) is expected, got "
                        f"{type(text).__name__}")
        self.text = text
        self.name = name or "model"
        self._handle = _create(text, 2, 1, 3, label=self.name)
        self._settings = []  # (name, value as given) in the order set
        n, m = _clib.ctypes.c_int(), _clib.ctypes.c_int()
        _check(_clib.QUAD.sizes(self._handle.pointer, n, m), self._handle)
        self.n, self.m = n.value, m.value
        count = _clib.QUAD.parameter_count(self._handle.pointer)
        #: Parameter names, in the order of the file.
        self.parameter_names = tuple(self._name(_clib.NAME_PARAMETER, i + 1)
                                     for i in range(count))
        #: Coordinate names q1..qn.
        self.coordinate_names = tuple(self._name(_clib.NAME_COORDINATE, i + 1)
                                      for i in range(self.n))
        #: Momentum names p1..pn.
        self.momentum_names = tuple(self._name(_clib.NAME_MOMENTUM, i + 1)
                                    for i in range(self.n))

    def _name(self, what, index):
        handle = self._handle.pointer
        length = _clib.QUAD.model_name(handle, what, index, None, 0)
        if length < 0:
            raise Error(length, _clib.QUAD.message_of(handle))
        buffer = _clib.ctypes.create_string_buffer(length + 1)
        _clib.QUAD.model_name(handle, what, index, buffer, length + 1)
        return buffer.value.decode("utf-8")

    @classmethod
    def from_file(cls, path):
        """The model of a file (its errors say "PATH:LINE:COLUMN: ...")."""
        path = os.fspath(path)
        try:
            with open(path, encoding="utf-8") as stream:
                text = stream.read()
        except OSError as error:
            raise Error(INVALID_ARGUMENT, f"cannot read the model file {path}: "
                        f"{error.strerror}") from None
        return cls(text, name=path)

    @classmethod
    def builtin(cls, name):
        """A model shipped with the package: see :func:`builtin_models` (e.g. "pendulum",
        "planar_pendulum", "double_pendulum", "spring_linkage", "magnetic_sphere",
        "sphere_dumbbell", "water", "fourbar")."""
        available = builtin_models()
        if name not in available:
            raise Error(INVALID_ARGUMENT, f"no built-in model {name!r}; the built-in "
                        f"models are: {', '.join(available)}")
        model = cls.from_file(os.path.join(_MODELS_DIR, _ALIASES.get(name, name) + ".hsm"))
        model.name = name
        return model

    def save(self, path):
        """Write the model's text to a file (Model.from_file reads it back)."""
        with open(os.fspath(path), "w", encoding="utf-8") as stream:
            stream.write(self.text)

    def set(self, **values):
        """Set parameters by name, e.g. model.set(g=2.0, L="1/3"): each value rounded
        once to the nearest binary128 (for an integrator of precision="double": to the
        nearest double, from the value as given). Error(INVALID_ARGUMENT) for an unknown
        name or a value that is not finite (the model then keeps its earlier values).
        Returns the model."""
        for name, value in values.items():
            raw = _real_bytes(value, f"parameter {name}")
            buffer = _clib.QUAD.reals(1, raw)
            _check(_clib.QUAD.set_parameter_p(self._handle.pointer, name.encode("utf-8"),
                                              buffer.address), self._handle)
            self._settings.append((name, value))
        return self

    def get(self, name):
        """The value of a parameter (binary128), exactly (Decimal)."""
        buffer = _clib.QUAD.reals(1)
        _check(_clib.QUAD.get_parameter(self._handle.pointer, name.encode("utf-8"),
                                        buffer.address), self._handle)
        return binary128.to_decimal(buffer.get_bytes())

    @property
    def parameters(self):
        """{name: Decimal} of every parameter's current value."""
        return {name: self.get(name) for name in self.parameter_names}

    def initial_state(self):
        """(q, p): the start the model states with its current parameters (velocities
        turned into momenta, projected onto the manifold when off it), as Decimals of the
        real128 values."""
        q, p = _clib.QUAD.reals(self.n), _clib.QUAD.reals(self.n)
        _check(_clib.QUAD.initial_state(self._handle.pointer, q.address, p.address),
               self._handle)
        return _decimals(q.get_bytes()), _decimals(p.get_bytes())

    def _apply_settings(self, handle):
        """Set the parameters set so far on a handle (of either library), each value
        rounded once to that library's reals."""
        lib = handle.lib
        for name, value in self._settings:
            buffer = lib.reals(1, _real_bytes(value, f"parameter {name}", lib))
            _check(lib.set_parameter_p(handle.pointer, name.encode("utf-8"),
                                       buffer.address), handle)

    def __repr__(self):
        return f"<holosym.Model {self.name} n={self.n} m={self.m}>"


# ---------------------------------------------------------------------------- integrator

def _orders(M, N, G):
    """(M, N, G) with the defaults of `holosym simulate`: N = M - 1, G = max(M, N) + 1."""
    if N is None and isinstance(M, (int, np.integer)):
        N = M - 1
    if G is None and isinstance(M, (int, np.integer)) and isinstance(N, (int, np.integer)):
        G = max(M, N) + 1
    return M, N, G


class Event:
    """An event located by Integrator.integrate_events: `index` of the function in the
    list given, `direction` (1: g rose through zero, -1: it fell), its time `t`, the state
    `q`, `p` and the multipliers `lam` there (floats, or Decimals with exact=True)."""

    __slots__ = ("index", "direction", "t", "q", "p", "lam", "offset")

    def __init__(self, index, direction, t, q, p, lam, offset):
        self.index, self.direction, self.t = index, direction, t
        self.q, self.p, self.lam = q, p, lam
        self.offset = offset  # the time from the run's start, exact (Fraction)

    def __repr__(self):
        return f"Event(index={self.index}, direction={self.direction}, t={self.t})"


class Integrator:
    """Step-by-step integration of a model with the symplectic scheme (M, N, G) (order
    2 min(M, N + 1) when G is large enough; defaults N = M - 1, G = M + 1).

    precision="quad" (default) integrates in real128, precision="double" in real64 (the
    real64 library); the state, h and the parameters are then reals of that precision.
    The state starts at the model's initial state, or at (q, p) given (any real inputs,
    rounded once to the precision). `h` is the default step size of step() and
    integrate(). The integrator owns a C handle; close() (or a with block) frees it
    early."""

    def __init__(self, model, M=8, N=None, G=None, h=None, q=None, p=None,
                 precision="quad"):
        lib = _library(precision)
        if not isinstance(model, Model):
            raise Error(INVALID_ARGUMENT, f"a holosym.Model is expected, got "
                        f"{type(model).__name__}")
        M, N, G = _orders(M, N, G)
        self.model = model
        self.orders = (M, N, G)
        #: "quad" or "double".
        self.precision = precision
        self._lib = lib
        self._codec = lib.codec
        self.n, self.m = model.n, model.m
        self._handle = _create(model.text, M, N, G, label=model.name, lib=lib)
        model._apply_settings(self._handle)
        self._q, self._p = lib.reals(self.n), lib.reals(self.n)
        self._h = None if h is None else self._step_bytes(h)
        #: The time of the state: the sum of the steps taken (exact, a Fraction).
        self.t = Fraction(0)
        self._pending = None
        if q is None and p is None:
            _check(lib.initial_state(self._handle.pointer, self._q.address,
                                     self._p.address), self._handle)
            #: The note of the model's start (e.g. that it was projected), or "".
            self.note = lib.message_of(self._handle.pointer)
        else:
            if q is None or p is None:
                raise Error(INVALID_ARGUMENT, "give both q and p, or neither")
            self.set_state(q, p)
            self.note = ""

    # -- state
    def set_state(self, q, p, t=0):
        """Set the state (each value rounded once to the integrator's precision) and the
        time t."""
        q_raw = _vector_bytes(q, self.n, "q", self._lib)
        p_raw = _vector_bytes(p, self.n, "p", self._lib)
        negative, t_value = binary128.parse_value(t)
        if not isinstance(t_value, Fraction):
            raise Error(INVALID_ARGUMENT, f"t must be finite, got {t!r}")
        self._q.set_bytes(q_raw)
        self._p.set_bytes(p_raw)
        self.t = -t_value if negative else t_value

    @property
    def state(self):
        """(q, p) as tuples of Decimals, every digit of the binary128 (or double)
        values."""
        lib = self._lib
        return _decimals(self._q.get_bytes(), lib), _decimals(self._p.get_bytes(), lib)

    @property
    def state_float(self):
        """(q, p) as numpy float64 arrays (rounded to nearest)."""
        lib = self._lib
        return _floats(self._q.get_bytes(), lib), _floats(self._p.get_bytes(), lib)

    @property
    def q(self):
        """q as a numpy float64 array."""
        return _floats(self._q.get_bytes(), self._lib)

    @property
    def p(self):
        """p as a numpy float64 array."""
        return _floats(self._p.get_bytes(), self._lib)

    def _step_bytes(self, h):
        return _real_bytes(h, "h", self._lib)

    def _h_buffer(self, h):
        if h is None:
            if self._h is None:
                raise Error(INVALID_STEP_SIZE, "no step size: give h here or to the "
                            "Integrator")
            raw = self._h
        else:
            raw = self._step_bytes(h)
        return self._lib.reals(1, raw), raw

    # -- the calls
    def step(self, h=None):
        """One step of size h (default: the integrator's h) in place. Error on failure,
        the state unchanged (h <= 0: INVALID_STEP_SIZE)."""
        buffer, raw = self._h_buffer(h)
        _check(self._lib.step_p(self._handle.pointer, self._q.address, self._p.address,
                                buffer.address), self._handle)
        self.t += self._codec.to_fraction(raw)

    def integrate(self, steps, h=None, observer=None, exact=False):
        """`steps` steps of size h in place; returns the number of steps done.

        observer(step, t, q, p) is called after each step (step from 1, t the time of the
        state, q and p float64 arrays; with exact=True t, q, p are Decimals). Inside it,
        integrator.dense_output(tau) evaluates the step just taken. A truthy return stops
        the run (no error: the steps done are returned); an exception raised by the
        observer stops it too and propagates from integrate. The state is then the last
        step's (also after an Error of the library: the last good step)."""
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)):
            raise Error(INVALID_STEP_COUNT, f"steps must be an int, got {steps!r}")
        buffer, raw = self._h_buffer(h)
        lib, codec = self._lib, self._codec
        h_value = codec.to_fraction(raw) if codec.to_decimal(raw).is_finite() else None
        t0 = self.t
        handle = self._handle.pointer
        n = self.n
        stopped = [False]
        size = lib.bytes * n

        def bridge(_handle, step, _t, q_ptr, p_ptr, _data):
            try:
                q_raw = _clib.ctypes.string_at(q_ptr, size)
                p_raw = _clib.ctypes.string_at(p_ptr, size)
                t = t0 + step * h_value
                if exact:
                    result = observer(step, _fraction_to_decimal(t), _decimals(q_raw, lib),
                                      _decimals(p_raw, lib))
                else:
                    result = observer(step, float(t), _floats(q_raw, lib),
                                      _floats(p_raw, lib))
                if result:
                    stopped[0] = True
                    return 1
                return 0
            except BaseException as error:  # re-raised after the C call returns
                self._pending = error
                return 1

        callback = _clib.OBSERVER(bridge) if observer is not None else None
        done = _clib.ctypes.c_int(0)
        self._pending = None
        code = lib.integrate_p(handle, self._q.address, self._p.address, buffer.address,
                               int(steps),
                               _clib.ctypes.cast(callback, _clib.ctypes.c_void_p)
                               if callback else None, None, done)
        if done.value > 0:
            self.t = t0 + done.value * h_value
        if self._pending is not None:
            pending, self._pending = self._pending, None
            raise pending
        if code == USER_ABORT and stopped[0]:
            return done.value
        _check(code, self._handle)
        return done.value

    def integrate_events(self, steps, events, h=None, directions=None, terminal=None,
                         exact=False):
        """`steps` steps of size h in place, locating the zero crossings of the event
        functions (docs/events.md); returns (found, stopped).

        events: a list of functions g(t, q, p) -> real (t a float and q, p float64 arrays;
        with exact=True Decimals with every digit, and g may return a Decimal, Fraction
        or str: the event times then have the library's precision, which float values of
        g limit to about 1e-16). directions: per function 0 (any), 1 (g rising through
        zero) or -1 (falling); terminal: per function, True ends the run at the event.
        found: a list of Event (index into events, direction, t, q, p, lam), in time
        order; stopped: a terminal event ended the run, and the state is the event's.
        An exception raised by g stops the run and propagates; Error for the library's
        failures (the state is then the last good step's)."""
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)):
            raise Error(INVALID_STEP_COUNT, f"steps must be an int, got {steps!r}")
        events = list(events)
        count = len(events)
        buffer, raw = self._h_buffer(h)
        lib, codec = self._lib, self._codec
        h_value = codec.to_fraction(raw) if codec.to_decimal(raw).is_finite() else None
        size = lib.bytes * self.n
        convert = _decimals if exact else _floats
        found = []

        def value(k, t_ptr, q_ptr, p_ptr, value_ptr, _data):
            try:
                t = t0 + codec.to_fraction(_clib.ctypes.string_at(t_ptr, lib.bytes))
                t = _fraction_to_decimal(t) if exact else float(t)
                g = events[k - 1](t, convert(_clib.ctypes.string_at(q_ptr, size), lib),
                                  convert(_clib.ctypes.string_at(p_ptr, size), lib))
                g_raw = _real_bytes(g, f"event function {k - 1}", lib)
                _clib.ctypes.memmove(value_ptr, g_raw, lib.bytes)
                return 0
            except BaseException as error:  # re-raised after the C call returns
                if self._pending is None:
                    self._pending = error
                return 1

        def receive(k, direction, t_ptr, q_ptr, p_ptr, lam_ptr, _data):
            # The library's t counts from the run's start.
            offset = codec.to_fraction(_clib.ctypes.string_at(t_ptr, lib.bytes))
            t = t0 + offset
            found.append(Event(k - 1, direction,
                               _fraction_to_decimal(t) if exact else float(t),
                               convert(_clib.ctypes.string_at(q_ptr, size), lib),
                               convert(_clib.ctypes.string_at(p_ptr, size), lib),
                               convert(_clib.ctypes.string_at(lam_ptr, lib.bytes * self.m),
                                       lib), offset))
            return 0

        def ints(values, what):
            if values is None:
                return None
            values = [int(v) for v in values]
            if len(values) != count:
                raise Error(SIZE_MISMATCH, f"{what}: {count} values expected, got "
                            f"{len(values)}")
            return (_clib.ctypes.c_int * max(count, 1))(*values)

        direction_array = ints(directions, "directions")
        terminal_array = ints(terminal, "terminal")
        g_callback = _clib.EVENT_FUNCTION(value)
        found_callback = _clib.EVENT_FOUND(receive)
        done = _clib.ctypes.c_int(0)
        stopped = _clib.ctypes.c_int(0)
        t0 = self.t
        self._pending = None
        code = lib.integrate_events(
            self._handle.pointer, self._q.address, self._p.address, buffer.address,
            int(steps), count, _clib.ctypes.cast(g_callback, _clib.ctypes.c_void_p),
            direction_array, terminal_array,
            _clib.ctypes.cast(found_callback, _clib.ctypes.c_void_p), None, done, stopped)
        if stopped.value:
            self.t = t0 + found[-1].offset
        elif done.value > 0:
            self.t = t0 + done.value * h_value
        if self._pending is not None:
            pending, self._pending = self._pending, None
            raise pending
        _check(code, self._handle)
        return found, bool(stopped.value)

    # -- the tangent map and Lyapunov exponents (docs/events.md)
    def _vectors(self, dq, dp):
        """(k, buffers of dq and dp) of k tangent vectors given as k x n arrays (one
        vector a row; a single vector may be a flat sequence of n values)."""
        rows = []
        for what, values in (("dq", dq), ("dp", dp)):
            array = np.asarray(values, dtype=object)
            if array.ndim == 1:
                array = array.reshape(1, -1)
            if array.ndim != 2 or array.shape[1] != self.n or array.shape[0] < 1:
                raise Error(SIZE_MISMATCH, f"{what}: k x {self.n} values expected (one "
                            f"vector a row), got shape {np.asarray(values).shape}")
            rows.append(array)
        if rows[0].shape != rows[1].shape:
            raise Error(SIZE_MISMATCH, f"dq and dp differ in shape: {rows[0].shape} and "
                        f"{rows[1].shape}")
        k = rows[0].shape[0]
        lib = self._lib
        buffers = [lib.reals(k * self.n, b"".join(
            _vector_bytes(row, self.n, f"{what}[{j}]", lib) for j, row in enumerate(array)))
            for what, array in zip(("dq", "dp"), rows)]
        return k, buffers[0], buffers[1]

    def _matrix(self, buffer, k, exact):
        """k x n float64 array of a buffer of k vectors, or with exact a tuple of k tuples
        of Decimals."""
        lib = self._lib
        raw = buffer.get_bytes()
        size = lib.bytes * self.n
        rows = [raw[j * size:(j + 1) * size] for j in range(k)]
        if exact:
            return tuple(_decimals(row, lib) for row in rows)
        return np.array([_floats(row, lib) for row in rows], dtype=float).reshape(k, self.n)

    def tangent_basis(self, exact=False):
        """An orthonormal basis of the tangent space of the constraint manifold at the
        state: (dq, dp), 2(n - m) x n each (vector j in row j), numpy float64 arrays or,
        with exact=True, tuples of Decimals (which step_tangent takes back without loss)."""
        lib = self._lib
        dimension = 2 * (self.n - self.m)
        dq, dp = lib.reals(max(dimension, 1) * self.n), lib.reals(max(dimension, 1) * self.n)
        count = _clib.ctypes.c_int(0)
        _check(lib.tangent_basis(self._handle.pointer, self._q.address, self._p.address,
                                 dq.address, dp.address, count), self._handle)
        return self._matrix(dq, count.value, exact), self._matrix(dp, count.value, exact)

    def project_tangent(self, dq, dp, exact=False):
        """The tangent vectors (dq, dp) (k x n each, a vector a row) projected orthogonally
        onto the tangent space at the state: (dq, dp) as tangent_basis returns them."""
        k, dq_buffer, dp_buffer = self._vectors(dq, dp)
        _check(self._lib.project_tangent(self._handle.pointer, self._q.address,
                                         self._p.address, k, dq_buffer.address,
                                         dp_buffer.address), self._handle)
        return self._matrix(dq_buffer, k, exact), self._matrix(dp_buffer, k, exact)

    def step_tangent(self, dq, dp, h=None, exact=False):
        """One step of size h in place (as step()) and the tangent map of the step: the
        derivative of the step map on the constraint manifold applied to the tangent
        vectors (dq, dp) at the start state (k x n each, a vector a row; tangent_basis
        gives a basis, project_tangent projects other vectors). Returns their images at
        the end state as tangent_basis returns vectors. Error(OFF_MANIFOLD) for a vector
        off the tangent space; on any Error the state is unchanged."""
        k, dq_buffer, dp_buffer = self._vectors(dq, dp)
        buffer, raw = self._h_buffer(h)
        _check(self._lib.step_tangent(self._handle.pointer, self._q.address,
                                      self._p.address, buffer.address, k,
                                      dq_buffer.address, dp_buffer.address), self._handle)
        self.t += self._codec.to_fraction(raw)
        return self._matrix(dq_buffer, k, exact), self._matrix(dp_buffer, k, exact)

    def lyapunov(self, steps, h=None):
        """The Lyapunov spectrum and MEGNO of the orbit from the state over `steps` steps
        of size h (Benettin's re-orthonormalisation of tangent vectors on the constraint
        manifold): returns (exponents, megno), the 2(n - m) exponents largest first as a
        float64 array and the mean MEGNO <Y> as a float. The state advances to the end of
        the steps taken (also on an Error, which then reports the failing step)."""
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)):
            raise Error(INVALID_STEP_COUNT, f"steps must be an int, got {steps!r}")
        lib = self._lib
        buffer, raw = self._h_buffer(h)
        exponents = lib.reals(max(2 * (self.n - self.m), 1))
        megno = lib.reals(1)
        done = _clib.ctypes.c_int(0)
        code = lib.lyapunov_spectrum(self._handle.pointer, self._q.address, self._p.address,
                                     buffer.address, int(steps), exponents.address,
                                     megno.address, done)
        if done.value > 0:
            self.t += done.value * self._codec.to_fraction(raw)
        _check(code, self._handle)
        values = _floats(exponents.get_bytes(), lib)[:2 * (self.n - self.m)]
        return values, float(_floats(megno.get_bytes(), lib)[0])

    def dense_output(self, tau, exact=False):
        """(q~, p~, lambda~) of the last step at tau in [0, 1] (numpy float64 arrays, or
        with exact=True tuples of Decimals). Error(NOT_INITIALIZED) before any step."""
        lib = self._lib
        tau_buffer = lib.reals(1, _real_bytes(tau, "tau", lib))
        q, p, lam = lib.reals(self.n), lib.reals(self.n), lib.reals(self.m)
        _check(lib.dense_output_p(self._handle.pointer, tau_buffer.address, q.address,
                                  p.address, lam.address), self._handle)
        convert = _decimals if exact else _floats
        return (convert(q.get_bytes(), lib), convert(p.get_bytes(), lib),
                convert(lam.get_bytes()[:lib.bytes * self.m], lib))

    def project(self):
        """Project the state onto the constraint manifold {phi = 0, Phi H_p = 0}."""
        _check(self._lib.project(self._handle.pointer, self._q.address, self._p.address),
               self._handle)

    def plan_accuracy(self, tolerance, T):
        """Set the integrator up for an error `tolerance` (max |error| of q and p) at time
        T from the state: holosym chooses (M, N, G), h and the Newton tolerance from a
        pilot (docs/accuracy.md). The chosen h becomes the integrator's h and `orders`
        the chosen (M, N, G); returns the number of steps to T, so that
        `integrator.integrate(integrator.plan_accuracy(1e-20, 10))` reaches T. Error on a
        bad request, the set-up unchanged."""
        lib = self._lib
        tolerance_buffer = lib.reals(1, _real_bytes(tolerance, "tolerance", lib))
        span_buffer = lib.reals(1, _real_bytes(T, "T", lib))
        h_buffer = lib.reals(1)
        steps = _clib.ctypes.c_int(0)
        orders = (_clib.ctypes.c_int * 3)()
        _check(lib.plan_accuracy(self._handle.pointer, self._q.address, self._p.address,
                                 tolerance_buffer.address, span_buffer.address,
                                 h_buffer.address, steps, orders), self._handle)
        self._h = h_buffer.get_bytes()
        self.orders = tuple(orders)
        return steps.value

    def energy(self, exact=False):
        """H at the state (float, or Decimal with exact=True)."""
        raw = self._energy_bytes(self._q, self._p)
        return self._codec.to_decimal(raw) if exact else self._codec.to_float(raw)

    def constraint(self, exact=False):
        """phi at the state (m values: float64 array, or Decimals with exact=True)."""
        raw = self._constraint_bytes(self._q)
        return _decimals(raw, self._lib) if exact else _floats(raw, self._lib)

    def _energy_bytes(self, q, p):
        out = self._lib.reals(1)
        _check(self._lib.energy(self._handle.pointer, q.address, p.address, out.address),
               self._handle)
        return out.get_bytes()

    def _constraint_bytes(self, q):
        out = self._lib.reals(self.m)
        _check(self._lib.constraint(self._handle.pointer, q.address, out.address),
               self._handle)
        return out.get_bytes()[:self._lib.bytes * self.m]

    def close(self):
        """Free the C handle (the integrator is unusable afterwards)."""
        self._handle.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return (f"<holosym.Integrator {self.model.name} (M, N, G) = {self.orders} "
                f"{self.precision}>")


def _fraction_to_decimal(x):
    """The exact Decimal of a Fraction whose denominator is a power of two."""
    den = x.denominator
    if den & (den - 1):
        raise ValueError("not a dyadic fraction")
    k = den.bit_length() - 1
    return binary128.to_decimal(binary128.from_value(0)) if x == 0 else \
        _decimal_exact(x.numerator, k)


def _decimal_exact(numerator, k):
    """numerator / 2**k exactly as a Decimal."""
    from decimal import Context, Inexact, Rounded
    digits = abs(numerator).bit_length() + k + 10
    context = Context(prec=digits, Emax=999999999, Emin=-999999999, traps=[Inexact, Rounded])
    return context.scaleb(context.multiply(Decimal(numerator), context.power(5, k)), -k)


# ---------------------------------------------------------------------------- runs

def _step_count(h_raw, T, steps, lib=_clib.QUAD):
    """The number of steps: `steps`, or nint(T/h) as `holosym simulate` takes it (h and
    T reals of `lib`)."""
    if steps is not None:
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 0:
            raise Error(INVALID_STEP_COUNT, f"steps must be an int >= 0, got {steps!r}")
        return int(steps)
    if T is None:
        raise Error(INVALID_ARGUMENT, "give T (the final time) or steps")
    codec = lib.codec
    h_dec = codec.to_decimal(h_raw)
    if not h_dec.is_finite() or h_dec <= 0:
        raise Error(INVALID_STEP_SIZE, f"h must be > 0 and finite, got {h_dec}")
    t_value = codec.to_decimal(_real_bytes(T, "T", lib))
    if not t_value.is_finite() or t_value < 0:
        raise Error(INVALID_ARGUMENT, f"T must be >= 0 and finite, got {T!r}")
    ratio = Fraction(t_value) / codec.to_fraction(h_raw)
    count = int(ratio + Fraction(1, 2))  # nint (ratio >= 0): half away from zero
    if count > 2147483647:
        raise Error(INVALID_STEP_COUNT, f"T/h gives {count} steps, more than 2147483647")
    return count


class Run:
    """The rows of :func:`simulate`: t = 0, every `every` steps and the last step.

    Arrays (numpy float64): t (rows), q and p (rows x n), energy (H, rows),
    energy_error ((H - H0)/H0 as `holosym simulate` writes it; H - H0 when H0 = 0),
    constraint_residual (max|phi| at the row's state; 0 when m = 0); float64 for either
    precision. exact(row) gives the row's (q, p) as Decimals with every digit of the
    binary128 values (precision "quad") or of the doubles (precision "double")."""

    def __init__(self, model, orders, h_raw, rows, energies, residuals, steps,
                 lib=_clib.QUAD):
        self.model = model
        self.orders = orders
        self.steps = steps
        #: "quad" or "double": the precision of the run.
        self.precision = lib.precision
        self._lib = lib
        codec = lib.codec
        self._h = h_raw
        self._rows = rows  # [(t bytes, q bytes, p bytes)]
        self._energies = energies
        self.t = np.array([codec.to_float(r[0]) for r in rows], dtype=float)
        self.q = np.array([_floats(r[1], lib) for r in rows],
                          dtype=float).reshape(len(rows), -1)
        self.p = np.array([_floats(r[2], lib) for r in rows],
                          dtype=float).reshape(len(rows), -1)
        self.energy = np.array([codec.to_float(e) for e in energies], dtype=float)
        h0 = codec.to_fraction(energies[0])
        scale = h0 if h0 != 0 else Fraction(1)
        self.energy_error = np.array(
            [float((codec.to_fraction(e) - h0) / scale) for e in energies], dtype=float)
        self.constraint_residual = np.array(residuals, dtype=float)

    @property
    def h(self):
        """The step size as used (binary128 or double), exactly."""
        return self._lib.codec.to_decimal(self._h)

    def __len__(self):
        return len(self._rows)

    def exact(self, row):
        """(q, p) of a row (negative: from the end) as tuples of Decimals, exact."""
        _, q, p = self._rows[row]
        return _decimals(q, self._lib), _decimals(p, self._lib)

    def exact_t(self, row):
        """t of a row as a Decimal, exact (the library's k h in its precision)."""
        return self._lib.codec.to_decimal(self._rows[row][0])

    def exact_energy(self, row):
        """H of a row as a Decimal, exact."""
        return self._lib.codec.to_decimal(self._energies[row])

    def __repr__(self):
        return (f"<holosym.Run {self.model.name} (M, N, G) = {self.orders} "
                f"{self.precision}, {len(self)} rows>")


def _residual(integrator, q_buffer):
    """max|phi(q)| as a float (0 when m = 0), from the exact values."""
    raw = integrator._constraint_bytes(q_buffer)
    lib = integrator._lib
    values = [abs(lib.codec.to_fraction(piece)) for piece in lib.split(raw)]
    return float(max(values)) if values else 0.0


def simulate(model, M=8, N=None, G=None, h=None, T=None, steps=None, every=1, q=None,
             p=None, precision="quad"):
    """Integrate `model` from its initial state (or (q, p)) like `holosym simulate`:
    (M, N, G) with N = M - 1 and G = max(M, N) + 1 by default, step size h (str, Decimal,
    Fraction, int or float), nint(T/h) steps (or `steps`), a row at t = 0, every `every`
    steps and after the last. precision="quad" (default) runs the real128 library,
    "double" the real64 one (every input rounded once to a double; like `holosym
    simulate` of the real64 build). Returns a :class:`Run`; Error on a failure."""
    lib = _library(precision)
    codec = lib.codec
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise Error(INVALID_ARGUMENT, f"every must be an int >= 1, got {every!r}")
    if h is None:
        raise Error(INVALID_STEP_SIZE, "give the step size h")
    h_raw = _real_bytes(h, "h", lib)
    count = _step_count(h_raw, T, steps, lib)
    integrator = Integrator(model, M, N, G, h=h, q=q, p=p, precision=precision)
    try:
        rows = [(codec.from_value(0), integrator._q.get_bytes(),
                 integrator._p.get_bytes())]
        size = lib.bytes * integrator.n
        handle = integrator._handle.pointer
        pending = []

        def record(_handle, step, t_ptr, q_ptr, p_ptr, _data):
            try:
                if step % every == 0 or step == count:
                    rows.append((_clib.ctypes.string_at(t_ptr, lib.bytes),
                                 _clib.ctypes.string_at(q_ptr, size),
                                 _clib.ctypes.string_at(p_ptr, size)))
                return 0
            except BaseException as error:  # pragma: no cover - memory errors
                pending.append(error)
                return 1

        callback = _clib.OBSERVER(record)
        h_buffer = lib.reals(1, h_raw)
        done = _clib.ctypes.c_int(0)
        code = lib.integrate_p(handle, integrator._q.address, integrator._p.address,
                               h_buffer.address, count,
                               _clib.ctypes.cast(callback, _clib.ctypes.c_void_p), None,
                               done)
        if pending:
            raise pending[0]
        _check(code, integrator._handle)
        energies, residuals = [], []
        q_buffer, p_buffer = lib.reals(integrator.n), lib.reals(integrator.n)
        for _, q_raw, p_raw in rows:
            q_buffer.set_bytes(q_raw)
            p_buffer.set_bytes(p_raw)
            energies.append(integrator._energy_bytes(q_buffer, p_buffer))
            residuals.append(_residual(integrator, q_buffer))
        return Run(model, integrator.orders, h_raw, rows, energies, residuals, done.value,
                   lib)
    finally:
        integrator.close()


class EnsembleResult:
    """The final states of :func:`ensemble`, one row per member: q and p (members x n),
    energy_error ((H - H0)/H0 at the end) and constraint_residual (max|phi| at the end)
    as numpy float64 arrays, status (int array, 0 for success) and messages (str list);
    a failed member's row is NaN. exact(i) gives member i's final (q, p) as Decimals
    (of the binary128 values, or of the doubles for precision="double")."""

    def __init__(self, n, lib=_clib.QUAD):
        self.n = n
        #: "quad" or "double": the precision of the members' runs.
        self.precision = lib.precision
        self._lib = lib
        self._finals = []
        self.status = []
        self.messages = []
        self.energy_error = []
        self.constraint_residual = []

    def _finish(self):
        nan_row = [float("nan")] * self.n
        lib = self._lib
        self.q = np.array([_floats(f[0], lib) if f else nan_row for f in self._finals],
                          dtype=float).reshape(len(self._finals), self.n)
        self.p = np.array([_floats(f[1], lib) if f else nan_row for f in self._finals],
                          dtype=float).reshape(len(self._finals), self.n)
        self.energy_error = np.array(self.energy_error, dtype=float)
        self.constraint_residual = np.array(self.constraint_residual, dtype=float)
        self.status = np.array(self.status, dtype=int)

    def __len__(self):
        return len(self._finals)

    def exact(self, member):
        """Member's final (q, p) as tuples of Decimals (Error for a failed member)."""
        final = self._finals[member]
        if final is None:
            raise Error(int(self.status[member]), self.messages[member])
        return _decimals(final[0], self._lib), _decimals(final[1], self._lib)


def ensemble(model, states, M=8, N=None, G=None, h=None, T=None, steps=None,
             errors="raise", precision="quad"):
    """Integrate `model` from each of `states` (an iterable of (q, p) pairs of real
    inputs) over nint(T/h) steps (or `steps`) with (M, N, G) and step size h; returns an
    :class:`EnsembleResult` of the final states.

    The members run one after another on one integrator in this process (a loop over
    the C interface; the library's own ensembles, `holosym ensemble`, run in parallel).
    errors="raise": the first failing member raises Error (its index in the message);
    errors="record": failures are recorded in status/messages and the loop goes on.
    precision="quad" (default) or "double" as for :func:`simulate`."""
    lib = _library(precision)
    codec = lib.codec
    if errors not in ("raise", "record"):
        raise Error(INVALID_ARGUMENT, f"errors must be 'raise' or 'record', got {errors!r}")
    if h is None:
        raise Error(INVALID_STEP_SIZE, "give the step size h")
    h_raw = _real_bytes(h, "h", lib)
    count = _step_count(h_raw, T, steps, lib)
    members = list(states)
    result = EnsembleResult(model.n, lib)
    with Integrator(model, M, N, G, h=h, precision=precision) as integrator:
        for index, state in enumerate(members):
            try:
                q, p = state
                integrator.set_state(q, p)
                h0 = codec.to_fraction(integrator._energy_bytes(integrator._q,
                                                                integrator._p))
                integrator.integrate(count)
                energy = codec.to_fraction(integrator._energy_bytes(integrator._q,
                                                                    integrator._p))
            except (Error, TypeError, ValueError) as error:
                if not isinstance(error, Error):
                    error = Error(INVALID_ARGUMENT, f"states[{index}]: {error}")
                if errors == "raise":
                    raise Error(error.code, f"ensemble member {index}: "
                                f"{error.message}") from None
                result._finals.append(None)
                result.status.append(error.code)
                result.messages.append(error.message)
                result.energy_error.append(float("nan"))
                result.constraint_residual.append(float("nan"))
                continue
            result._finals.append((integrator._q.get_bytes(), integrator._p.get_bytes()))
            result.status.append(SUCCESS)
            result.messages.append("")
            scale = h0 if h0 != 0 else Fraction(1)
            result.energy_error.append(float((energy - h0) / scale))
            result.constraint_residual.append(_residual(integrator, integrator._q))
    result._finish()
    return result
