"""Data to validate the toolkit against, made by code nobody here wrote or by closed forms:

- :mod:`.integrators`: RK4 and :func:`scipy.integrate.solve_ivp` integrators of the continuous
  spring-mass equations (``nf.reference_simulate``, ``nf.reference_experiment``);
- :mod:`.continuum`: scikit-fem's quadratic tetrahedra, linear elasticity with Kelvin–Voigt
  damping (``pip install 'neurofuzzy[validation]'``);
- :mod:`.nonlinear`: sfepy's total-Lagrangian hyperelastic and viscoelastic solids and the
  closed forms they are checked against (``pip install 'neurofuzzy[validation-nonlinear]'``,
  which builds sfepy from its source: minutes);
- :mod:`.plates`: FElupe's locking-free quadratic tetrahedra (the Hu–Washizu three-field
  form), a neo-Hookean cube compressed between plates, read at embedded beads (the
  ``validation`` extra; the recordings in ``tests/data/plates_nu*.npz``);
- :mod:`.plate_ramp`: the same cube with inertia and Kelvin–Voigt viscosity, its plate ramped
  in time (FElupe's elements, a Newmark integration written here; the recordings in
  ``tests/data/plate_ramp_nu*.npz``);
- :mod:`.probed_block`: recordings of the probed soft block (scikit-fem, MuJoCo) and the models
  a user would build for it.

The toolkit's own code imports none of it but :mod:`neurofuzzy.datasets` (the paper cube's
RK4 data); each module loads its solver only when used.
"""
