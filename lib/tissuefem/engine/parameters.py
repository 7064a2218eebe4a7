"""The one home of the library's input checks, and Lamé constants from Young's modulus and Poisson's ratio.

Every number the library accepts has a documented range (the constants below), chosen so that what is accepted
can also be computed: ``E^2``, ``rho0 A / dt^2``, a penalty's ``k d^2`` stay finite; ``nu`` keeps ``1e-6``
from each end of ``(-1, 0.5)``, where ``lam + 2 mu / 3`` would be lost to round-off; points and radii are
measured in domain sizes ``L`` (the larger side of the domain's bounding box); counts are true integers (never
``bool``). Each refusal is a :class:`ParameterError` whose message names the argument and the allowed range
and whose ``field`` is that argument.
"""

from __future__ import annotations

import math
import numbers
import reprlib

import numpy as np

__all__ = [
    "ParameterError", "lame_parameters", "check_poisson_ratio", "check_lame", "check_real", "check_real_number",
    "check_count", "check_positive", "call_user", "check_list", "check_vector", "check_bounded_vector",
    "check_real_array", "check_indices", "check_reach", "check_radius", "check_weights", "check_fiber_stiffness",
    "check_time_step", "check_density", "check_contact_stiffness", "check_penalty_stiffness", "YOUNGS_MODULUS_RANGE",
    "POISSON_RATIO_RANGE", "LAME_MAX", "SHEAR_MODULUS_MIN", "TIME_STEP_RANGE", "DENSITY_RANGE", "ACCELERATION_MAX",
    "FORCE_MAX", "PENALTY_MAX", "PENALTY_STIFFNESS_MAX", "CONTACT_STIFFNESS_MAX", "REACH", "RADIUS_RANGE",
    # a scene's tables: each refusal names the field (``effects.probes[0].radius``)
    "show", "number", "is_sequence", "vector", "points", "table", "require", "string", "count_list", "penalty",
    "FAR", "MAX_POINTS", "MAX_STRING", "FIBER_STIFFNESS_RANGE",
]

YOUNGS_MODULUS_RANGE = (1e-6, 1e12)  #: Young's modulus (closed interval, as every range here)
POISSON_RATIO_RANGE = (-1.0 + 1e-6, 0.5 - 1e-6)  #: Poisson's ratio, inside the admissible (-1, 0.5)
LAME_MAX = 1e30  #: the largest Lamé parameter (and fibre modulus) given directly
SHEAR_MODULUS_MIN = 1e-7  #: the smallest shear modulus given directly (``E >= 1e-6`` maps to ``mu > 1e-6 / 3``)
TIME_STEP_RANGE = (1e-6, 10.0)  #: time steps, in seconds
DENSITY_RANGE = (1e-6, 1e6)  #: densities (mass per unit reference area)
ACCELERATION_MAX = 1e6  #: the largest component of a gravitational acceleration
FORCE_MAX = 1e12  #: the largest component of a body force (per unit area) or a traction (per unit length)
#: the largest penalty stiffness of a probe or a suture in a scene's table, before Young's modulus is known (when
#: the model is built, :func:`check_penalty_stiffness` caps it relative to Young's modulus)
PENALTY_MAX = 1e40
#: the stiffest probe, in Young's moduli per unit of its radius, and the stiffest suture, in Young's moduli: 1e4 times
#: their defaults (``100 E / radius``, ``100 E``; :func:`check_penalty_stiffness` says why)
PENALTY_STIFFNESS_MAX = 1e6
#: the stiffest self-contact, in Young's moduli (:func:`check_contact_stiffness` says why)
CONTACT_STIFFNESS_MAX = 1e4
REACH = 1e3  #: points and displacements lie within ``REACH`` domain sizes (of the domain's centre, for points)
RADIUS_RANGE = (1e-6, 1e3)  #: radii (probes, grabs), in domain sizes


class ParameterError(ValueError):
    """A refused input: a ``ValueError`` whose ``field`` names the offending argument (``"probe.radius"``); callers
    that relabel an error (a scene file's section, a command-line option) read ``field``, not the message."""

    def __init__(self, field: str, message: str):
        super().__init__(message)
        self.field = field


def check_real_number(name: str, value) -> float:
    """``value`` as a float if it is a real number (not a bool, a string or a complex number); NaN and infinities
    pass (:func:`check_real` refuses them)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ParameterError(name, f"{name} must be a real number, got {value!r}")
    try:
        return float(value)
    except OverflowError:  # an integer with hundreds of digits
        raise ParameterError(name, f"{name} is out of range (too large for a float), got {show(value)}") \
            from None


def check_real(name: str, value, lo=None, hi=None, *, lo_open: bool = False, hi_open: bool = False) -> float:
    """``value`` as a finite float within ``[lo, hi]`` (ends open on request; ``None``: unbounded), else a
    ``ParameterError`` naming ``name`` (also for bools, strings, complex numbers and integers too large)."""
    v = check_real_number(name, value)
    if not math.isfinite(v):
        raise ParameterError(name, f"{name} must be finite, got {value!r}")
    violated = None
    if lo is not None and (v <= lo if lo_open else v < lo):
        violated = "> 0" if (lo == 0 and lo_open) or (v <= 0 < lo) else f"{'>' if lo_open else '>='} {lo:g}"
    elif hi is not None and (v >= hi if hi_open else v > hi):
        violated = f"{'<' if hi_open else '<='} {hi:g}"
    if violated is not None:
        lo_text, hi_text = "-inf" if lo is None else f"{lo:g}", "inf" if hi is None else f"{hi:g}"
        allowed = f"{'(' if lo_open else '['}{lo_text}, {hi_text}{')' if hi_open else ']'}"
        raise ParameterError(name, f"{name} must be {violated} (allowed range {allowed}), got {show(value)}")
    return v


def check_count(name: str, value, lo: int = 1, hi: int | None = None) -> int:
    """``value`` as an int within ``[lo, hi]``: a true integer (``int``, numpy integer), never a ``bool`` or a float."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise ParameterError(name, f"{name} must be an integer, got {show(value)}")
    v = int(value)
    if v < lo or (hi is not None and v > hi):
        bounds = f"[{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise ParameterError(name, f"{name} must be an integer in {bounds}, got {show(value)}")
    return v


def check_positive(name, value) -> float:
    """A finite real number ``> 0``, or a ``ValueError`` naming ``name``."""
    return check_real(name, value, 0.0, lo_open=True)


def call_user(field: str, what: str, function, *args):
    """``function(*args)`` for a user's callable (a ``what``: mask, map, clock); whatever it raises is refused
    as a ``ParameterError`` naming ``field``."""
    try:
        return function(*args)
    except Exception as err:  # a user's callable may raise anything: a refusal, not a crash
        raise ParameterError(field, f"{field}: the {what} raised {type(err).__name__}: {err}") from None


def check_list(name: str, value, what: str) -> list:
    """``list(value)``, else a ``ParameterError`` naming ``name``: ``value`` must be a sequence of ``what``."""
    try:
        return list(value)
    except TypeError:
        raise ParameterError(name, f"{name} must be a sequence of {what}, got {show(value)}") from None


def check_vector(name, value, size: int = 2) -> np.ndarray:
    """A finite vector ``(x, y)`` (``size=3``: ``(x, y, z)``) of real numbers, or a ``ValueError`` naming ``name``."""
    try:
        v = np.asarray(value)
    except (TypeError, ValueError):  # ragged lists
        v = np.asarray(None)
    # strings, booleans, objects are refused; complex would lose its imaginary part
    if v.dtype.kind not in "iuf" or v.shape != (size,) or not np.all(np.isfinite(v)):
        xy = "(x, y)" if size == 2 else "(x, y, z)"
        raise ParameterError(name, f"{name} must be a finite vector {xy} of real numbers, got {value!r}")
    return v.astype(float)


def check_indices(name: str, value, count: int, what: str = "indices") -> np.ndarray:
    """``value`` as a 1D array of indices (``what``) in ``0 .. count-1``: true integers, never floats or
    bools."""
    try:
        idx = np.asarray(value)
    except (TypeError, ValueError):  # ragged lists
        idx = np.asarray(None)
    if idx.ndim != 1 or not (idx.size == 0 or idx.dtype.kind in "iu"):
        raise ParameterError(name, f"{name} must be a list of integer {what} in 0..{count - 1}, "
                                   f"got {show(value)}")
    if idx.size and (idx.min() < 0 or idx.max() >= count):
        raise ParameterError(name, f"{name} must be {what} in 0..{count - 1} (there are {count}), "
                                   f"got {show(value)}")
    return idx.astype(np.intp)


def check_reach(name, point, middle, size, where="") -> np.ndarray:
    """``point`` if it lies within ``REACH`` domain sizes of the domain's centre ``middle``, else ``ValueError``
    (``where``, said of the domain, ends the message)."""
    far = REACH * size
    if np.any(np.abs(np.asarray(point) - middle) > far):
        raise ParameterError(name, f"{name} = {np.asarray(point).tolist()} lies farther than {REACH:g} domain sizes "
                                   f"({far:g}) from the domain's centre ({', '.join(f'{c:g}' for c in middle)}){where}")
    return point


def check_radius(name, radius: float, size, where="") -> float:
    """A radius (a positive number) within :data:`RADIUS_RANGE` domain sizes ``size``: a tool's default stiffness
    (``~ E / r``), its penalty and its depths stay finite (``where``, said of the domain, ends the message)."""
    lo, hi = RADIUS_RANGE[0] * size, RADIUS_RANGE[1] * size
    if not lo <= radius <= hi:
        raise ParameterError(name, f"{name} = {radius:g} must lie within [{RADIUS_RANGE[0]:g}, {RADIUS_RANGE[1]:g}] "
                                   f"domain sizes, i.e. [{lo:g}, {hi:g}]{where}")
    return radius


def check_weights(weights, m) -> np.ndarray:
    """Per-element material fractions: ``m`` real numbers in ``(0, 1]`` (complex or boolean ones are refused)."""
    w = np.array(check_real_array("weights", weights))  # a copy: the caller's array may change
    if w.shape != (m,) or not (np.all(np.isfinite(w)) and np.all(w > 0) and np.all(w <= 1)):
        raise ParameterError("weights", f"weights must be one number in (0, 1] per element, shape ({m},), "
                                        f"got {show(weights)}")
    return w


def check_fiber_stiffness(k, name: str = "k") -> float:
    """Validate a fiber modulus: a real number in ``[0, LAME_MAX]`` (1e30); the error names the argument ``name``."""
    return check_real(f"{name} (fiber modulus)", k, 0.0, LAME_MAX)


def check_time_step(dt) -> float:
    """A time step in seconds within :data:`TIME_STEP_RANGE`."""
    return check_real("dt (time step)", dt, *TIME_STEP_RANGE)


def check_density(rho) -> float:
    """A density (mass per unit reference area) within :data:`DENSITY_RANGE`."""
    return check_real("density", rho, *DENSITY_RANGE)


def _check_stiffness(name, stiffness, hi, times, what, positive) -> float:
    value = check_real_number(name, stiffness)
    if not (math.isfinite(value) and (0.0 < value if positive else 0.0 <= value) and value <= hi):
        raise ParameterError(name, f"{name} must be in {'(' if positive else '['}0, {hi:g}] ({times}: stiffer, the "
                                   f"{what}'s energy hides the elastic energy in round-off and the solver throws "
                                   f"nodes), got {show(stiffness)}")
    return value


def check_contact_stiffness(name: str, stiffness, modulus) -> float:
    """A self-contact stiffness (a pressure) in ``(0, CONTACT_STIFFNESS_MAX * modulus]``, ``modulus`` the material's
    Young's modulus. Stiffer buys nothing visible (at a pressure of ``modulus`` a point sinks under 1 % of the skin's
    depth at the bound) and the barrier's energy swamps the elastic energy's round-off: the line search cannot see
    the tissue any more, frames stop converging, and from about ``1e16`` moduli nodes are thrown across the scene."""
    return _check_stiffness(name, stiffness, CONTACT_STIFFNESS_MAX * modulus,
                            f"{CONTACT_STIFFNESS_MAX:g} times Young's modulus {modulus:g}", "contact", True)


def check_penalty_stiffness(name: str, stiffness, modulus, radius=None, *, positive: bool = False) -> float:
    """A probe's (``radius`` given) or a suture's penalty stiffness in ``[0, hi]`` (``(0, hi]`` if ``positive``):
    ``hi = PENALTY_STIFFNESS_MAX * modulus / radius`` (a probe: a pressure per unit penetration) or
    ``PENALTY_STIFFNESS_MAX * modulus`` (a suture: a force per unit length), ``modulus`` the material's Young's
    modulus. Stiffer buys nothing visible (at the bound a probe pressed with a pressure of ``modulus`` sinks a
    millionth of its radius, a suture pulled with a force of ``modulus`` stretches by 1e-6) and the
    penalty's energy swamps the elastic energy's round-off: the line search cannot see the tissue any more, and from
    about ``1e11 modulus / radius`` (probes) or ``1e16 modulus`` (sutures) nodes are thrown across the scene while
    the frames still report convergence."""
    unit = f"Young's modulus {modulus:g}" + ("" if radius is None else f" per radius {radius:g}")
    return _check_stiffness(name, stiffness, PENALTY_STIFFNESS_MAX * modulus / (1.0 if radius is None else radius),
                            f"{PENALTY_STIFFNESS_MAX:g} times {unit}", "penalty", positive)


def check_bounded_vector(name: str, value, bound: float, size: int = 2) -> np.ndarray:
    """A vector ``(x, y)`` (``size=3``: ``(x, y, z)``) of real numbers each within ``+-bound``, else a ``ValueError``
    naming ``name`` (refused like :func:`check_real`: bools, strings, complex numbers, NaN, infinities, and vectors of
    another shape)."""
    if not is_sequence(value) or len(value) != size:
        what = "(x, y) of two" if size == 2 else "(x, y, z) of three"
        raise ParameterError(name, f"{name} must be a vector {what} real numbers, got {show(value)}")
    return np.array([check_real(f"{name}[{i}]", v, -bound, bound) for i, v in enumerate(value)])


def check_poisson_ratio(nu, name: str = "nu (Poisson's ratio)") -> float:
    """Poisson's ratio in :data:`POISSON_RATIO_RANGE`; within ``1e-6`` of an end of ``(-1, 0.5)`` the message
    says it is too close (``lam/mu > 5e5``, or huge ``lam``, ``mu`` of opposite sign)."""
    nu = check_real(name, nu, -1.0, 0.5, lo_open=True, hi_open=True)
    lo, hi = POISSON_RATIO_RANGE
    if not lo <= nu <= hi:
        raise ParameterError(name, f"{name} = {nu!r} is too close to {'0.5' if nu > 0 else '-1'}; the allowed "
                                   f"range is [{lo:.6f}, {hi:.6f}]")
    return nu


def lame_parameters(E, nu, plane: str = "strain") -> tuple[float, float]:
    """Lamé parameters ``(lam, mu)`` from Young's modulus and Poisson's ratio (:data:`YOUNGS_MODULUS_RANGE`,
    :func:`check_poisson_ratio`).

    ``lam = E nu / ((1 + nu)(1 - 2 nu))``, ``mu = E / (2 (1 + nu))`` (the notes' formula, Young's modulus written K):
    plane strain in 2D; ``plane="stress"`` gives ``lam* = 2 lam mu / (lam + 2 mu)`` (linear elasticity of thin
    sheets). ``-1 < nu < 0.5`` (the notes say "between 0 and 1/2"; auxetic ``nu < 0`` is admissible too); ``nu -> 0.5``
    makes ``lam`` blow up: nearly incompressible.
    """
    E, nu = check_real("E (Young's modulus)", E, *YOUNGS_MODULUS_RANGE), check_poisson_ratio(nu)
    lam, mu = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu))
    if plane == "strain":
        return lam, mu
    if plane == "stress":
        return 2.0 * lam * mu / (lam + 2.0 * mu), mu
    raise ParameterError("plane", f"plane must be 'strain' or 'stress', got {plane!r}")


def check_lame(lam, mu) -> tuple[float, float]:
    """Lamé parameters given directly: ``mu`` in ``[1e-7, 1e30]``, ``-2 mu / 3 < lam <= 1e30`` (a positive
    bulk modulus: exactly what ``-1 < nu < 0.5`` maps to)."""
    mu = check_real("mu (shear modulus)", mu, SHEAR_MODULUS_MIN, LAME_MAX)
    lam = check_real("lam (first Lamé parameter)", lam, -2.0 * mu / 3.0, LAME_MAX, lo_open=True)
    return lam, mu


def check_real_array(name: str, value) -> np.ndarray:
    """``value`` as a float array, else a ``ValueError`` naming ``name``: strings, ragged lists, objects, booleans
    and complex numbers are refused (``np.asarray(..., dtype=float)`` would drop an imaginary part with a warning)."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):  # ragged nested lists
        raise ParameterError(name, f"{name} must be an array of real numbers, got a {type(value).__name__} "
                                   "that is not rectangular (ragged)") from None
    if a.dtype.kind not in "iuf":
        what = {"c": "complex numbers", "b": "booleans", "U": "strings", "S": "bytes", "O": "Python objects"}
        raise ParameterError(name, f"{name} must be an array of real numbers, got "
                                   f"{what.get(a.dtype.kind, a.dtype)} (dtype {a.dtype})")
    return a if a.dtype == np.float64 else a.astype(np.float64)


# --------------------------------------------------------------------------------------------- a scene's tables

#: points and lengths before the domain's size is known: beyond REACH times the largest domain
FAR = 1e10
MAX_POINTS = 10_000
MAX_STRING = 10_000
FIBER_STIFFNESS_RANGE = (0.0, 1e12)

_REPR = reprlib.Repr()
_REPR.maxstring = _REPR.maxother = 60
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = 6
_REPR.maxlevel = 3


def show(value) -> str:
    """A short, one-line rendering of any value for an error message (bounded however large or deep it is)."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f"an integer of {len(str(value)) if value.bit_length() < 10_000 else 'thousands of'} digits"
    try:
        return _REPR.repr(value)
    except Exception:  # a foreign object whose repr fails
        return f"a {type(value).__name__}"


def number(field, value, *, positive=False, integer=False, lo=None, hi=None):
    """``value`` as a number for ``field`` within ``[lo, hi]`` (``positive``: within ``(0, hi]``, ``lo`` unused);
    with ``integer`` (and ``lo``), a float such as ``800.0`` is refused."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(field, f"{field} must be a number, got {show(value)}")
    if integer:
        return check_count(field, value, int(lo), None if hi is None else int(hi))
    return check_real(field, value, 0.0 if positive else lo, hi, lo_open=positive)


def is_sequence(value) -> bool:
    return isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim == 1)


def vector(field, value, bound=FAR) -> list:
    """A scene's vector: ``[x, y]`` or ``[x, y, z]`` (the scene checks it against its mesh's dimension)."""
    if not is_sequence(value) or len(value) not in (2, 3):
        raise ParameterError(field, f"{field} must be a vector [x, y] (3D: [x, y, z]), got {show(value)}")
    return [number(f"{field}[{i}]", c, lo=-bound, hi=bound) for i, c in enumerate(value)]


def points(field, value, minimum, maximum=MAX_POINTS) -> list:
    if not is_sequence(value) or not minimum <= len(value) <= maximum:
        count = minimum if minimum == maximum else f"{minimum} to {maximum}"
        raise ParameterError(field, f"{field} must be a list of {count} points [x, y], got {show(value)}")
    return [vector(f"{field}[{i}]", p) for i, p in enumerate(value)]


def table(field, value, allowed=None) -> dict:
    """``value`` if it is a table (a dict) with no keys but ``allowed`` (if given)."""
    if not isinstance(value, dict):
        raise ParameterError(field, f"{field} must be a table (a dict), got {show(value)}")
    unknown = [] if allowed is None else [k for k in value if k not in allowed]  # keys may be of any type
    if unknown:
        shown = sorted(show(k) for k in unknown)
        raise ParameterError(field, f"{field}: unknown key(s) [{', '.join(shown)}]; allowed: {sorted(allowed)}")
    return value


def require(field, value, keys) -> dict:
    """``value`` (a table) if it has every key of ``keys``."""
    for key in keys:
        if key not in value:
            raise ParameterError(f"{field}.{key}", f"{field}.{key}: missing")
    return value


def string(field, value, choices=None, *, nonempty=False) -> str:
    """A string (one of ``choices`` if given) that a UTF-8 scene file can hold, at most ``MAX_STRING`` long."""
    if choices is not None:
        if not isinstance(value, str) or value not in choices:
            raise ParameterError(field, f"{field} must be one of {list(choices)}, got {show(value)}")
        return value
    if not isinstance(value, str):
        raise ParameterError(field, f"{field} must be a string, got {show(value)}")
    if len(value) > MAX_STRING:
        raise ParameterError(field, f"{field} must be at most {MAX_STRING} characters long, got {len(value)}")
    if nonempty and not value:
        raise ParameterError(field, f"{field} must not be empty")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError as err:  # a lone surrogate: no UTF-8 file (TOML or JSON) can hold it
        raise ParameterError(field, f"{field} contains a lone surrogate code point at character {err.start} (not "
                                    "text that a scene file can hold)") from None
    return value


def count_list(field, value, what, maximum) -> list:
    if not is_sequence(value) or len(value) == 0:  # (an array has no truth value)
        raise ParameterError(field, f"{field} must be a non-empty list of {what}, got {show(value)}")
    if len(value) > maximum:
        raise ParameterError(field, f"{field}: at most {maximum} {what}, got {len(value)}")
    return value


def penalty(field, value, positive=False) -> float:
    return number(field, value, positive=positive, lo=0.0, hi=PENALTY_MAX)
