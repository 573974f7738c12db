"""3×3 matrices as row-major tuples of nine scalars (symmetric ones as their six entries
``(00, 11, 22, 01, 02, 12)``), for the element loops of the compiled sweeps
(:mod:`.sensitivity`, :mod:`.adjoint`): inlined, they keep an element's F, Ḟ, S and their
tangents in registers."""

import numba


@numba.njit(cache=True, nogil=True, inline="always")
def _edges(x, n0, n1, n2, n3, B):
    """``Dx B`` (``Dx`` columns: x1 - x0, x2 - x0, x3 - x0) of node values ``x`` (N, 3)."""
    d1 = (x[n1, 0] - x[n0, 0], x[n2, 0] - x[n0, 0], x[n3, 0] - x[n0, 0])
    d2 = (x[n1, 1] - x[n0, 1], x[n2, 1] - x[n0, 1], x[n3, 1] - x[n0, 1])
    d3 = (x[n1, 2] - x[n0, 2], x[n2, 2] - x[n0, 2], x[n3, 2] - x[n0, 2])
    return _mul(d1 + d2 + d3, (B[0, 0], B[0, 1], B[0, 2], B[1, 0], B[1, 1], B[1, 2],
                                B[2, 0], B[2, 1], B[2, 2]))


@numba.njit(cache=True, nogil=True, inline="always")
def _differences(x, n0, n1, n2, n3, q):
    """``Dx`` of tangent ``q`` of ``x`` (N, 3, P), row-major."""
    return (x[n1, 0, q] - x[n0, 0, q], x[n2, 0, q] - x[n0, 0, q], x[n3, 0, q] - x[n0, 0, q],
            x[n1, 1, q] - x[n0, 1, q], x[n2, 1, q] - x[n0, 1, q], x[n3, 1, q] - x[n0, 1, q],
            x[n1, 2, q] - x[n0, 2, q], x[n2, 2, q] - x[n0, 2, q], x[n3, 2, q] - x[n0, 2, q])


@numba.njit(cache=True, nogil=True, inline="always")
def _mul(a, b):
    """``a b``."""
    return (a[0] * b[0] + a[1] * b[3] + a[2] * b[6], a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
            a[0] * b[2] + a[1] * b[5] + a[2] * b[8], a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
            a[3] * b[1] + a[4] * b[4] + a[5] * b[7], a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
            a[6] * b[0] + a[7] * b[3] + a[8] * b[6], a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
            a[6] * b[2] + a[7] * b[5] + a[8] * b[8])


@numba.njit(cache=True, nogil=True, inline="always")
def _sym_t_mul(a, b):
    """``sym(aᵀ b)`` as its six entries ``(00, 11, 22, 01, 02, 12)``."""
    c00 = a[0] * b[0] + a[3] * b[3] + a[6] * b[6]
    c11 = a[1] * b[1] + a[4] * b[4] + a[7] * b[7]
    c22 = a[2] * b[2] + a[5] * b[5] + a[8] * b[8]
    c01 = 0.5 * (a[0] * b[1] + a[3] * b[4] + a[6] * b[7] + a[1] * b[0] + a[4] * b[3]
                 + a[7] * b[6])
    c02 = 0.5 * (a[0] * b[2] + a[3] * b[5] + a[6] * b[8] + a[2] * b[0] + a[5] * b[3]
                 + a[8] * b[6])
    c12 = 0.5 * (a[1] * b[2] + a[4] * b[5] + a[7] * b[8] + a[2] * b[1] + a[5] * b[4]
                 + a[8] * b[7])
    return c00, c11, c22, c01, c02, c12


@numba.njit(cache=True, nogil=True, inline="always")
def _full(s):
    """The symmetric matrix of six entries ``(00, 11, 22, 01, 02, 12)``, row-major."""
    return (s[0], s[3], s[4], s[3], s[1], s[5], s[4], s[5], s[2])


@numba.njit(cache=True, nogil=True, inline="always")
def _dot(a, b):
    """``a : b`` of two row-major 3×3 tuples."""
    return (a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4]
            + a[5] * b[5] + a[6] * b[6] + a[7] * b[7] + a[8] * b[8])


@numba.njit(cache=True, nogil=True, inline="always")
def _sym_dot(a, b):
    """``a : b`` of two symmetric matrices given by their six entries."""
    return (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
            + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]))


@numba.njit(cache=True, nogil=True, inline="always")
def _scatter(out, P, B, scale, n0, n1, n2, n3, q):
    """Node j + 1 gets column j of ``scale P Bᵀ``, node 0 minus their sum: into ``out``
    (N, 3) when ``q < 0``, else into tangent ``q`` of ``out`` (N, 3, P)."""
    for r in range(3):
        P0, P1, P2 = P[3 * r], P[3 * r + 1], P[3 * r + 2]
        f1 = scale * (P0 * B[0, 0] + P1 * B[0, 1] + P2 * B[0, 2])
        f2 = scale * (P0 * B[1, 0] + P1 * B[1, 1] + P2 * B[1, 2])
        f3 = scale * (P0 * B[2, 0] + P1 * B[2, 1] + P2 * B[2, 2])
        if q < 0:
            out[n1, r] += f1
            out[n2, r] += f2
            out[n3, r] += f3
            out[n0, r] -= f1 + f2 + f3
        else:
            out[n1, r, q] += f1
            out[n2, r, q] += f2
            out[n3, r, q] += f3
            out[n0, r, q] -= f1 + f2 + f3


@numba.njit(cache=True, nogil=True, inline="always")
def _green(F, Fd):
    """``(G, Ġ)`` of ``F``, ``Ḟ``: ``½(FᵀF - I)`` and ``sym(FᵀḞ)``, six entries each."""
    C = _sym_t_mul(F, F)
    return ((0.5 * (C[0] - 1.0), 0.5 * (C[1] - 1.0), 0.5 * (C[2] - 1.0), 0.5 * C[3],
             0.5 * C[4], 0.5 * C[5]), _sym_t_mul(F, Fd))


@numba.njit(cache=True, nogil=True, inline="always")
def _element_strains(p, v, tets, inverse_rest, e):
    """Element ``e`` opened: its nodes ``n0 .. n3``, ``B`` (its inverse rest edges), ``F``,
    ``Ḟ`` (nine scalars each), ``G`` and ``Ġ`` (six entries each), as one tuple."""
    n0, n1, n2, n3 = tets[e, 0], tets[e, 1], tets[e, 2], tets[e, 3]
    B = inverse_rest[e]
    F = _edges(p, n0, n1, n2, n3, B)
    Fd = _edges(v, n0, n1, n2, n3, B)
    G, Gd = _green(F, Fd)
    return n0, n1, n2, n3, B, F, Fd, G, Gd


@numba.njit(cache=True, nogil=True, inline="always")
def _edges_of_tangent(x, n0, n1, n2, n3, B, q):
    """``Dx B`` of tangent ``q`` of ``x`` (N, 3, P)."""
    D = _differences(x, n0, n1, n2, n3, q)
    return _mul(D, (B[0, 0], B[0, 1], B[0, 2], B[1, 0], B[1, 1], B[1, 2], B[2, 0], B[2, 1],
                    B[2, 2]))
