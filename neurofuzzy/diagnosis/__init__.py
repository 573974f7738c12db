"""Find the missing effect: where simulation and measurement disagree, name it, add it, refit.

Each round (DESIGN.md, "Diagnosis"):

1. fit the model as it is (:func:`neurofuzzy.fit`, as every refit);
2. residuals: the trajectory error of the free run and the one-step residual force
   ``r_i(t) = m_i a_i(t) - F_model,i(p(t), v(t)) - f_ext,i(t)`` with the measured state (positions
   smoothed by a Savitzky–Golay filter when the markers are noisy). One-step residuals do not
   accumulate, the insight behind the paper's teacher forcing;
3. localise ``r`` per node, per spring (a ridge regression of ``r`` on every spring's own force
   template gives each spring's stiffness mismatch) and per frame, and estimate the noise floor;
4. score every candidate of the effect catalogue by regressing ``r`` on its force templates
   together with the model's own parameter templates (sparse identification of dynamics, as in
   SINDy): the Bayesian information criterion with the noise floor as variance, ``ΔBIC =
   (RSS_model - RSS_model+candidate) / σ² - k ln n``, favours the simpler explanation;
5. decide against the lack of fit (:mod:`neurofuzzy.learn.lack_of_fit`), not the noise alone:
   while the fitted model explains the data to the noise, ``none`` unless a candidate explains
   a good share of the residual with strong evidence; while it does not, the best candidate of
   every kind with strong evidence is refitted (from the fitted model and, if that stays above
   the noise, from the start model's values), best scored first and no further once one
   leaves nothing significant above the noise (the rest could only tie within it), and the
   best refit is added when it shrinks the gap (RMS above the noise floor) at least
   ``MIN_SHRINK`` times; repeat. When
   nothing does and the model still misses the data, the answer is ``unexplained`` (never
   ``none``), with where and when the misfit lives, and for element models how much of it
   the mesh refined once explains.

Element models and markers embedded anywhere are diagnosed in trajectory space instead
(:mod:`.trajectory`): the evidence is the fitted model's free-run marker error, candidates are
scored by the sensitivities of the error to their parameters (a linearised refit), and an
inclusion is a ball of elements with extra Young's modulus. There the candidates are refitted
at one step (the candidate model's stable substeps; :mod:`.refits`) and only the winner's fit
is made as every fit is, at two steps and extrapolated (Richardson): the second step, twice as
fine, was two thirds of every refit's work. A recording with many frames of motion is
diagnosed on its first ones and the answer fitted on all of them (:mod:`.window`).

With the rule base as a prior (``diagnose(..., prior=FuzzyPrior(rules, model))``), an
inclusion found is also located item by item (:mod:`.localise`): every element or spring is
fitted with the prior and the regions found say where the tissue differs from its description.

From measured data, with the start :func:`neurofuzzy.fit` would take and the outcome checked
as a fit's is, the diagnosis is :func:`diagnose_data` (what ``neurofuzzy diagnose`` runs).
"""

from .from_data import DiagnosedData, diagnose_data
from .localise import Localisation, localise
from .loop import Diagnosis, Finding, diagnose
from .residuals import Residuals, residual_analysis
from .scoring import Candidate

__all__ = ["diagnose", "diagnose_data", "DiagnosedData", "Diagnosis", "Finding", "Candidate",
           "Residuals", "residual_analysis", "localise", "Localisation"]
