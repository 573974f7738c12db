"""The spring's force law, written once: the magnitude of paper eq. 3.4 with the spring effects'
strain stiffening, and its partial derivatives. Every spring force in the package takes its
magnitude from here: the compiled sweeps (:func:`neurofuzzy.kernels.stepper.spring_state`) per
spring, the numpy reference (:class:`neurofuzzy.forces.Springs`, the stiff inclusion's and
the stiffening's shapes) over arrays through :func:`magnitudes`.

A spring of stretch ``x = l - L0`` whose ends separate at speed ``ẋ`` pulls them together
with the magnitude (along ``u``, node a +, node b -)::

    m = s x + c ẋ + q x³,     ∂m/∂l = s + 3 q x²,     ∂m/∂(s, c, q) = (x, ẋ, x³)

``s`` the stiffness (N/m, with a stiff inclusion's extra), ``c`` the damping (N·s/m) and
``q = κ / L0²`` the stiffening's cubic constant (N/m³, 0 for none). The direction, the
scatter to the nodes and the derivatives of ``f = m u`` are kinematics, not law: the numpy
reference writes them over arrays, the kernels with scalars inside their loops.
"""

import numba

#: The bases of :func:`partial`, named by what multiplies the constant: ``x`` (the stiffness),
#: ``ẋ`` (the damping), ``x³`` (the cubic constant).
STRETCH, CLOSING, CUBIC = 0, 1, 2


@numba.njit(cache=True, nogil=True, inline="always")
def magnitude(stiffness, damping, cubic, stretch, closing):
    """``(m, ∂m/∂l)`` of one spring (module docstring); ``cubic == 0`` costs one test."""
    value = stiffness * stretch + damping * closing
    slope = stiffness
    if cubic != 0.0:                   # compiled away where the caller passes 0.0
        square = cubic * stretch * stretch
        value += square * stretch
        slope += 3.0 * square
    return value, slope


@numba.njit(cache=True, nogil=True, inline="always")
def partial(basis, stretch, closing):
    """``∂m/∂s``, ``∂m/∂c`` or ``∂m/∂q`` (``basis`` :data:`STRETCH`, :data:`CLOSING`,
    :data:`CUBIC`) of one spring."""
    if basis == STRETCH:
        return stretch
    if basis == CLOSING:
        return closing
    return stretch * stretch * stretch


# the numpy reference's: ufuncs (numpy's broadcasting and call cost, under a microsecond
# through ``.ufunc``; a numba function of arrays costs about one per argument to dispatch, and
# the paper learner steps the 86-spring cube in 50 µs)
@numba.vectorize(["float64(float64, float64, float64, float64, float64)"], cache=True)
def _value(stiffness, damping, cubic, stretch, closing):
    return magnitude(stiffness, damping, cubic, stretch, closing)[0]


@numba.vectorize(["float64(float64, float64, float64, float64, float64)"], cache=True)
def _slope(stiffness, damping, cubic, stretch, closing):
    return magnitude(stiffness, damping, cubic, stretch, closing)[1]


@numba.vectorize(["float64(int64, float64, float64)"], cache=True)
def _partial(basis, stretch, closing):
    return partial(basis, stretch, closing)


def magnitudes(stretch, closing=0.0, *, stiffness=0.0, damping=0.0, cubic=0.0):
    """``(m, ∂m/∂l)`` of n springs: :func:`magnitude` over arrays (the numpy reference's),
    every argument a scalar or an (n,) array, broadcast as numpy does."""
    return (_value.ufunc(stiffness, damping, cubic, stretch, closing),
            _slope.ufunc(stiffness, damping, cubic, stretch, closing))


def values(stretch, closing=0.0, *, stiffness=0.0, damping=0.0, cubic=0.0):
    """``m`` alone (:func:`magnitudes`' first)."""
    return _value.ufunc(stiffness, damping, cubic, stretch, closing)


def partials(basis: int, stretch, closing=0.0):
    """:func:`partial` of n springs over arrays (the numpy reference's)."""
    return _partial.ufunc(basis, stretch, closing)
