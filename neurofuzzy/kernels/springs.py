"""The spring's force law, written once: the magnitude of paper eq. 3.4 with the spring effects'
strain stiffening, and its partial derivatives. Every spring force in the package takes its
magnitude from here: the compiled sweeps (:func:`neurofuzzy.kernels.stepper.spring_state`) per
spring, the numpy reference (:class:`neurofuzzy.forces.SpringForce`, the stiff inclusion's and
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
import numpy as np

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


@numba.njit(cache=True, nogil=True)
def _magnitudes(stiffness, damping, cubic, stretch, closing, value, slope):
    for j in range(stretch.shape[0]):
        value[j], slope[j] = magnitude(stiffness[j], damping[j], cubic[j], stretch[j],
                                       closing[j])


@numba.njit(cache=True, nogil=True)
def _partials(basis, stretch, closing, out):
    for j in range(stretch.shape[0]):
        out[j] = partial(basis, stretch[j], closing[j])


def magnitudes(stretch, closing=0.0, *, stiffness=0.0, damping=0.0, cubic=0.0):
    """``(m, ∂m/∂l)``, each (n,), of n springs: :func:`magnitude` over arrays (the numpy
    reference's). Every argument is a scalar or an (n,) array."""
    stretch = np.asarray(stretch, dtype=float)
    args = [np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), stretch.shape))
            for x in (stiffness, damping, cubic, stretch, closing)]
    value, slope = np.empty(stretch.shape), np.empty(stretch.shape)
    _magnitudes(*args, value, slope)
    return value, slope


def partials(basis: int, stretch, closing=0.0):
    """(n,) :func:`partial` of n springs over arrays (the numpy reference's)."""
    stretch = np.ascontiguousarray(stretch, dtype=float)
    closing = np.ascontiguousarray(np.broadcast_to(np.asarray(closing, dtype=float),
                                                   stretch.shape))
    out = np.empty(stretch.shape)
    _partials(basis, stretch, closing, out)
    return out
