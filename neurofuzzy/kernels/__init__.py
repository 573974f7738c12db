"""The compiled (numba) kernels: one semi-implicit Euler update (:mod:`.integrator`), the
elements' material law with its two derivatives (:mod:`.svk`), and the sweeps that call them:
the stepper (:mod:`.stepper`, :func:`neurofuzzy.simulate`), the forward sensitivities
(:mod:`.sensitivity`) and the discrete adjoint (:mod:`.adjoint`) of the gradient learner.

Nothing is imported here: each module compiles (or loads from numba's cache) on first use.
"""
