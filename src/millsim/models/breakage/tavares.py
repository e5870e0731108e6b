"""Tavares (UFRJ) breakage model with sphere replacement (Tavares et al. 2021): the equations.

Pure functions, SI units throughout: sizes in m, masses in kg, specific energies in J/kg on the
*absorbed* basis (the energy the particle itself stores, after the eq 4 split). Percentages are
used only where the paper uses them: A, t10, t_n and cumulative passing are in %.

Pieces, in the order the engine meets them:

- eqs 1-3: each particle carries a fracture energy E drawn from an upper-truncated lognormal
  whose median falls with size (``sample_fracture_energy``).
- eq 4: the contact energy is split between the two bodies by stiffness (``energy_share``).
- eqs 5-6: an event that does not break the particle weakens it (``damage_fraction``, compiled).
- eqs 7-9: a broken particle's progeny fineness t10' (``t10_prime``).
- eq 10: t10' -> t_n by the regularised incomplete beta (``t_n``); eqs 11-13: fines and
  resolved-unbreakable extensions (``fines_passing``, ``cumulative_passing``).
- families (Tavares and Chagas 2021, module ``progeny_families``): discrete, mass-conserving sets
  of spheres whose probability-weighted mean reproduces the t_n curve (``families``), and
  ``break_particle`` (module ``progeny_placement``), which draws one and places it inside the
  parent.

This module holds the constants, ``TavaresMaterial`` and the equations; the materials file is read
by ``tavares_materials``; those three modules import from this one, never the reverse.
Choices where the paper text is ambiguous are documented in docs/tavares.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit
from scipy import special

from .damage import damage_fraction

# ---- constants ------------------------------------------------------------------------------
N_VALUES = (1.2, 1.5, 2.0, 4.0, 25.0, 50.0, 75.0)
"""The seven n of eq 10 (t_n = % passing d/n); n = 10 is t10 itself."""

SIEVE_RATIO = 2.0**0.25
"""Progeny sizes lie on the fourth-root-of-2 series x_k = 2^(-k/4) (Tavares et al. 2021,
Table 2)."""

STANDARD_CLASSES = 9
"""Resolved classes per family: x_min = 2^(-9/4) = 0.210 of the parent (Tavares et al. 2021,
section 2.2)."""

TABLE1_AVERAGE = ((0.448, 10.508), (0.706, 7.913), (0.959, 5.780), (1.105, 2.619),
                  (0.981, 0.524), (0.956, 0.339), (0.934, 0.255))
"""(alpha_n, beta_n) of eq 10 averaged over 40 materials, Table 1 of Tavares et al. 2021, in
N_VALUES order."""

KWH_PER_T = 3600.0  # J/kg in one kWh/t
T10_STEP = 0.1  # % ; families are tabulated on this t10' grid (paper: nearest tabulated set)
STEEL_STIFFNESS = 210e9 / (1.0 - 0.3**2)  # Pa, Y/(1 - nu^2) of steel (Tavares et al. 2021, Table 5)
ENERGY_BASES = ("stress_vs_steel", "absorbed")
KAPPA_PLACEMENTS = ("numerator", "denominator")
FAMILY_TN = ("table1_average", "material")
CUT_POLICIES = ("standard", "truncate")
MIN_TRUNCATED_CLASSES = 4  # a truncated family still reaches down to x = 1/2 of the parent


def stiffness(young, poisson):
    """Hertzian stiffness k = Y/(1 - nu^2) [Pa]: what splits the energy in eq 4."""
    return young / (1.0 - poisson * poisson)


def _choice(where, value, allowed):
    if value not in allowed:
        raise ValueError(f"{where}: {value!r} is not one of {', '.join(allowed)}")
    return value


# ---- material -------------------------------------------------------------------------------
@dataclass(frozen=True)
class TavaresMaterial:
    """One material of the Tavares model, SI units.

    Elastic: density [kg/m3], young [Pa], poisson [-]. Breakage (None for a material that never
    breaks, e.g. steel): E_inf [J/kg] on the basis ``E_inf_basis``, d0 [m], phi [-] (eq 3);
    sigma [-] and Emax_over_E50 [-] (eqs 1-2); gamma [-] (eq 6); A [%], b_prime [-] (eqs 7-9);
    alpha_n, beta_n (eq 10, N_VALUES order). kappa / kappa_placement: eq 8 option.
    device_stiffness [Pa]: k of the surface the breakage tests were made on (eq 3).
    fines_lambda: Gaudin-Schuhmann exponent of eq 11 (None = eq 12 from t4 and t75).
    family_tn: which (alpha_n, beta_n) build the families ("table1_average" as the paper, or
    "material"). family_classes: resolved classes per family (9 -> x_min = 0.210).
    e_min [J/kg]: smallest absorbed specific energy that damages (0 = all events).
    """

    name: str
    density: float
    young: float
    poisson: float
    E_inf: float | None = None
    d0: float | None = None
    phi: float | None = None
    sigma: float | None = None
    Emax_over_E50: float = 100.0
    gamma: float | None = None
    A: float | None = None
    b_prime: float | None = None
    alpha_n: tuple = ()
    beta_n: tuple = ()
    kappa: float = 1.0
    kappa_placement: str = "numerator"
    E_inf_basis: str = "stress_vs_steel"
    device_stiffness: float = STEEL_STIFFNESS
    fines_lambda: float | None = None
    family_tn: str = "table1_average"
    family_classes: int = STANDARD_CLASSES
    e_min: float = 0.0
    source: str = field(default="", compare=False)

    def __post_init__(self):
        _choice(f"{self.name}.kappa_placement", self.kappa_placement, KAPPA_PLACEMENTS)
        _choice(f"{self.name}.E_inf_basis", self.E_inf_basis, ENERGY_BASES)
        _choice(f"{self.name}.family_tn", self.family_tn, FAMILY_TN)
        if self.breakable and not (len(self.alpha_n) == len(self.beta_n) == len(N_VALUES)):
            raise ValueError(f"{self.name}: alpha_n and beta_n need {len(N_VALUES)} values "
                             f"(n = {N_VALUES})")

    @property
    def k(self):
        """Hertzian stiffness Y/(1 - nu^2) [Pa]."""
        return stiffness(self.young, self.poisson)

    @property
    def breakable(self):
        return self.E_inf is not None

    @property
    def tn_params(self):
        """(alpha_n, beta_n) pairs of the material, N_VALUES order (eq 10 and eq 13)."""
        return tuple(zip(self.alpha_n, self.beta_n))

    @property
    def family_params(self):
        """(alpha_n, beta_n) the families are built from (Table 1 average unless 'material')."""
        return TABLE1_AVERAGE if self.family_tn == "table1_average" else self.tn_params

    def require_breakage(self):
        if not self.breakable:
            raise ValueError(f"material {self.name!r} has no breakage parameters (never breaks)")


# ---- eqs 1-3: fracture energy ---------------------------------------------------------------
def absorbed_share_of_test_energy(mat):
    """ks/(kp + ks): the part of the test energy the particle itself absorbed (eq 3 factor).

    With E_inf on the stress-vs-steel basis (energy delivered against the test surface), only
    this share was stored in the particle (Hertz contacts in series, eq 4); 1 on the absorbed basis.
    """
    if mat.E_inf_basis == "absorbed":
        return 1.0
    return energy_share(mat.k, mat.device_stiffness)


def median_fracture_energy(mat, d):
    """E50(d) = ks/(kp+ks) E_inf [1 + (d0/d)^phi] [J/kg absorbed] (eq 3).

    Smaller particles are stronger per unit mass (fewer, smaller flaws).
    """
    mat.require_breakage()
    d = np.asarray(d, dtype=float)
    return absorbed_share_of_test_energy(mat) * mat.E_inf * (1.0 + (mat.d0 / d) ** mat.phi)


def truncated_lognormal_cdf(E, E50, Emax, sigma):
    """Eqs 1-2: P(E) = Phi(ln(E*/E50)/sigma), E* = E Emax/(Emax - E); 0 at E <= 0, 1 at >= Emax."""
    E, E50, Emax = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (E, E50, Emax)))
    out = np.where(E >= Emax, 1.0, 0.0)
    inside = (E > 0) & (E < Emax)
    Es = E[inside] * Emax[inside] / (Emax[inside] - E[inside])
    out[inside] = special.ndtr(np.log(Es / E50[inside]) / sigma)
    return out[()] if out.ndim == 0 else out


def truncated_lognormal_ppf(u, E50, Emax, sigma):
    """Inverse of eqs 1-2: E* = E50 exp(sigma Phi^-1(u)), E = E* Emax/(Emax + E*) in (0, Emax).

    u is clipped to [1e-16, 1 - 1e-16] so a counter-based u = 0 still gives E > 0.
    """
    u = np.clip(np.asarray(u, dtype=float), 1e-16, 1.0 - 1e-16)
    Es = np.asarray(E50, dtype=float) * np.exp(sigma * special.ndtri(u))
    return Es * Emax / (Emax + Es)


def fracture_energy_cdf(mat, d, E):
    """Probability that a fresh particle of size d [m] breaks at absorbed specific energy E."""
    E50 = median_fracture_energy(mat, d)
    return truncated_lognormal_cdf(E, E50, mat.Emax_over_E50 * E50, mat.sigma)


def sample_fracture_energy(mat, d, u):
    """Fracture energies [J/kg absorbed] for sizes d [m] from the engine's uniforms u (vectorised).

    Inverse CDF, so the same u always gives the same E: determinism stays with the engine's RNG.
    """
    E50 = median_fracture_energy(mat, d)
    return truncated_lognormal_ppf(u, E50, mat.Emax_over_E50 * E50, mat.sigma)


# ---- eq 4 -----------------------------------------------------------------------------------
def energy_share(k_p, k_m):
    """e_p = k_m/(k_p + k_m): the particle's share of a contact's energy (eq 4).

    The two bodies' Hertzian approaches add in series under one force, so each stores energy in
    proportion to its compliance 1/k: the softer body takes more.
    """
    return k_m / (k_p + k_m)


# ---- eqs 5-6: damage (damage_fraction lives in .damage, which the step loop imports) --------
@njit(cache=True)
def damaged_energy(E, r, gamma):
    """E' = E (1 - D) after an unbroken event of ratio r (eq 5)."""
    return E * (1.0 - damage_fraction(r, gamma))


# ---- eqs 7-9: t10 ---------------------------------------------------------------------------
def t10_population(mat, specific_energy, E50b):
    """Eq 7: t10 = A [1 - exp(-b' Ek/E50b)] [%] for a batch (E50b: median of the broken ones)."""
    mat.require_breakage()
    return mat.A * (1.0 - np.exp(-mat.b_prime * np.asarray(specific_energy) / E50b))


def t10_prime(mat, specific_energy, fracture_energy, kappa=None, placement=None):
    """Eq 8: t10' [%] of one broken particle from its own (damaged) fracture energy E.

    placement "numerator": A[1 - exp(-b' kappa Ek'/(m E))]; "denominator":
    A[1 - exp(-b' Ek'/(m kappa E))]. Both reduce to the same thing at kappa = 1 (Tavares et al. 2021
    used 1).
    """
    mat.require_breakage()
    kappa = mat.kappa if kappa is None else kappa
    placement = mat.kappa_placement if placement is None else placement
    ratio = np.asarray(specific_energy, dtype=float) / np.asarray(fracture_energy, dtype=float)
    if placement == "numerator":
        x = kappa * ratio
    elif placement == "denominator":
        x = ratio / kappa
    else:
        raise ValueError(f"kappa_placement: {placement!r} is not one of {KAPPA_PLACEMENTS}")
    return mat.A * (1.0 - np.exp(-mat.b_prime * x))


def t10_min(mat, kappa=None, placement=None):
    """Eq 9: the t10' of a particle broken at exactly its fracture energy (primary breakage)."""
    return float(t10_prime(mat, 1.0, 1.0, kappa, placement))


# ---- eq 10 and the size distribution ---------------------------------------------------------
def _params(mat_or_params):
    if isinstance(mat_or_params, TavaresMaterial):
        return mat_or_params.tn_params
    return tuple(tuple(map(float, p)) for p in mat_or_params)


def t_n(t10, mat_or_params):
    """Eq 10: t_n = 100 I(t10/100; alpha_n, beta_n) [%], shape (..., 7) in N_VALUES order.

    mat_or_params: a TavaresMaterial (its own alpha_n, beta_n) or 7 (alpha, beta) pairs, e.g.
    TABLE1_AVERAGE. I is scipy's regularised incomplete beta (betainc).
    """
    p = np.array(_params(mat_or_params))
    x = np.clip(np.asarray(t10, dtype=float), 0.0, 100.0)[..., None] / 100.0
    return 100.0 * special.betainc(p[:, 0], p[:, 1], x)


def _tn_crossings(params, t10_max, num=400, tol=0.01):
    """t10 grid (num,) in (0, t10_max] and where each of t1.5, t2, ..., t75 (t10 included)
    exceeds the next coarser one by > tol [%] (num, 7)."""
    t10 = np.linspace(t10_max / num, t10_max, num)
    tn = t_n(t10, params)
    full = np.concatenate([tn[:, :4], t10[:, None], tn[:, 4:]], axis=1)
    return t10, np.diff(full, axis=1) > tol


def tn_ordering_violations(params, t10_max=100.0, num=400, tol=0.01):
    """t10 values [%] in (0, t10_max] where some t_n exceeds a coarser one by > tol [%].

    (Copper ore's Table 4 set has t1.5 above t1.2 by ~2e-5 % near saturation: harmless.)
    """
    t10, over = _tn_crossings(params, t10_max, num, tol)
    return t10[over.any(axis=1)]


def _knots(t10, params):
    """Sizes (ascending x/d) and cumulative passing [%] through the t_n points of eq 10."""
    tn = t_n(t10, params)
    P = np.array([100.0, *tn[:4], float(t10), *tn[4:]])
    P = np.minimum.accumulate(P)  # finer sieve never passes more (guards a bad parameter set)
    x = np.array([1.0] + [1.0 / n for n in (1.2, 1.5, 2.0, 4.0, 10.0, 25.0, 50.0, 75.0)])
    return x[::-1], np.maximum(P[::-1], 1e-300)


def fines_exponent(t10, mat_or_params, fines_lambda=None):
    """Eq 12: Gaudin-Schuhmann slope lambda = ln(t4/t75)/ln(75/4) (log-log line t4 -> t75)."""
    if fines_lambda is None and isinstance(mat_or_params, TavaresMaterial):
        fines_lambda = mat_or_params.fines_lambda
    if fines_lambda is not None:
        return float(fines_lambda)
    tn = t_n(t10, mat_or_params)
    return float(np.log(tn[3] / tn[6]) / np.log(75.0 / 4.0))


def cumulative_passing(t10, x_rel, mat_or_params, fines_lambda=None):
    """Progeny % passing x_rel = x/d for one breakage of intensity t10 (eq 10 curve).

    Log-log linear between the t_n points (x = 1 -> 100 %), Gaudin-Schuhmann below d/75 with
    eq 12's slope. This is also eq 13, the distribution a resolved-unbreakable particle stands
    for once its first-event t10' is known.
    """
    xs, Ps = _knots(float(t10), mat_or_params)
    x = np.asarray(x_rel, dtype=float)
    lam = fines_exponent(t10, mat_or_params, fines_lambda)
    with np.errstate(divide="ignore"):
        lx = np.log(np.clip(x, 1e-300, None))
    inner = np.exp(np.interp(lx, np.log(xs), np.log(Ps)))
    tail = Ps[0] * (np.clip(x, 0.0, None) / xs[0]) ** lam
    out = np.where(x >= 1.0, 100.0, np.where(x < xs[0], tail, inner))
    return out[()] if out.ndim == 0 else out


resolved_unbreakable_passing = cumulative_passing
"""Eq 13: a resolved-unbreakable particle stands for cumulative_passing(t10' of its first event)."""


def _family_curve(mat_or_params, fines_lambda):
    """(params, fines_lambda) of the curve an event's progeny follow: a material's family
    parameters (the set its families were built from) and its fixed slope, if any."""
    if isinstance(mat_or_params, TavaresMaterial):
        lam = mat_or_params.fines_lambda if fines_lambda is None else fines_lambda
        return mat_or_params.family_params, lam
    return mat_or_params, fines_lambda


def fines_passing(t10, x_rel, mat_or_params, x_min=SIEVE_RATIO**-STANDARD_CLASSES,
                  fines_lambda=None):
    """Eq 11: B(x), the fraction of an event's unresolved fines (the dummy share, all below
    x_min) finer than x_rel; B(x_min) = 1.

    The fines follow the same curve as the family that made them: B(x) = P(x)/P(x_min) with P
    the eq 10 curve at the event's t10' (``cumulative_passing``), which below d/75 is eq 11's
    Gaudin-Schuhmann line with eq 12's slope. A material passes its *family* parameters
    (``family_tn``), so the dummy share (P(x_min) of those parameters, on average over the
    families) and its spread agree and the mass passing d/10 is t10' on average. Tavares et
    al. 2021 write the power law from x_min itself; that line misses t10 by +9 % at t10' = 3 %
    with consistent parameters, and with the material's own t4/t75 beside Table 1 families by
    -54 % (limestone) to +21 % (granulite) (docs/tavares.md section 6).
    """
    params, lam = _family_curve(mat_or_params, fines_lambda)
    x = np.clip(np.asarray(x_rel, dtype=float), 0.0, None)
    pmin = float(cumulative_passing(t10, x_min, params, lam))
    out = np.minimum(cumulative_passing(t10, x, params, lam) / pmin, 1.0)
    return out[()] if out.ndim == 0 else out


def event_passing(t10, x_rel, mat_or_params, fines_lambda=None):
    """Modelled % passing of one replacement event: the eq 10 curve of the family parameters
    at its t10' (resolved progeny above x_min, their dummy share spread by ``fines_passing``
    below it, which is the same curve)."""
    params, lam = _family_curve(mat_or_params, fines_lambda)
    return cumulative_passing(t10, x_rel, params, lam)


__all__ = [
    "KWH_PER_T",
    "N_VALUES",
    "SIEVE_RATIO",
    "STANDARD_CLASSES",
    "STEEL_STIFFNESS",
    "T10_STEP",
    "TABLE1_AVERAGE",
    "TavaresMaterial",
    "absorbed_share_of_test_energy",
    "cumulative_passing",
    "damage_fraction",
    "damaged_energy",
    "energy_share",
    "event_passing",
    "fines_exponent",
    "fines_passing",
    "fracture_energy_cdf",
    "median_fracture_energy",
    "resolved_unbreakable_passing",
    "sample_fracture_energy",
    "stiffness",
    "t10_min",
    "t10_population",
    "t10_prime",
    "t_n",
    "tn_ordering_violations",
    "truncated_lognormal_cdf",
    "truncated_lognormal_ppf",
]
