"""Independent references for the breakage tests, coded from the published equations.

Tavares et al. 2021 (Powder Technol. 392, 473-488) eqs 1-12 as restated in
/work/shared/reference/tavares.md: root finding (brentq) for implicit or inverse relations,
scipy.special.betainc for eq 10, never the module under test. Shared by
tests/test_breakage_relations.py (the equations) and tests/test_breakage_verdicts.py (the
verification's expectations built on them).
"""

import functools
import math

from scipy import optimize, special

from millsim.models.breakage import progeny_families
from millsim.models.breakage import tavares as tv

BREAKABLE = ("copper_ore", "limestone", "granulite")
# Tavares et al. 2021, Table 5 steel (Y = 210 GPa, nu = 0.30); section 2.1: "ks is approximately
# 230 GPa".
K_STEEL = 210e9 / (1.0 - 0.30**2)
# Tavares et al. 2021, Table 1: (alpha_n, beta_n) averaged over 40 materials,
# n = 1.2, 1.5, 2, 4, 25, 50, 75.
PAPER_TABLE1 = {1.2: (0.448, 10.508), 1.5: (0.706, 7.913), 2.0: (0.959, 5.780),
               4.0: (1.105, 2.619), 25.0: (0.981, 0.524), 50.0: (0.956, 0.339),
               75.0: (0.934, 0.255)}
N_ORDER = (1.2, 1.5, 2.0, 4.0, 25.0, 50.0, 75.0)
X_MIN = 2.0 ** (-9.0 / 4.0)  # Tavares et al. 2021, section 2.2: x_min = 1/2^(9/4) = 0.210


def hertz_k(young, poisson):
    """Hertzian stiffness Y/(1 - nu^2) (Tavares et al. 2021, section 2.1)."""
    return young / (1.0 - poisson**2)


def ref_share(k_p, k_m):
    """Eq 4 from its derivation (Tavares et al. 2021, Appendix A): the two Hertz approaches add in
    series under one force, so each body stores energy in proportion to its compliance 1/k."""
    return (1.0 / k_p) / (1.0 / k_p + 1.0 / k_m)


def ref_E50(mat, d):
    """Eq 3 with the kp/ks factor (tavares.md section 3, EDEM form):
    E50 = E_inf / (1 + kp/ks) * [1 + (d0/d)^phi], on the absorbed basis."""
    kp = hertz_k(mat.young, mat.poisson)
    return mat.E_inf / (1.0 + kp / K_STEEL) * (1.0 + (mat.d0 / d) ** mat.phi)


def ref_cdf(E, E50, Emax, sigma):
    """Eqs 1-2: P = 1/2 [1 + erf((ln E* - ln E50) / sqrt(2 sigma^2))], E* = E Emax/(Emax - E)."""
    if E <= 0.0:
        return 0.0
    if E >= Emax:
        return 1.0
    Es = E * Emax / (Emax - E)
    return 0.5 * (1.0 + math.erf((math.log(Es) - math.log(E50)) / math.sqrt(2.0 * sigma**2)))


def ref_quantile(u, E50, Emax, sigma):
    """E with ref_cdf(E) = u, by root finding on eqs 1-2 (not by the closed-form inverse)."""
    return optimize.brentq(lambda E: ref_cdf(E, E50, Emax, sigma) - u, 1e-9 * E50,
                           Emax * (1.0 - 1e-13), xtol=1e-13 * E50, rtol=1e-14)


def ref_damage(r, gamma):
    """Eq 6, D = [2g/(2g - 5D + 5) r]^(2g/5), solved by brentq: g(D) = D - rhs(D) is < 0 at 0 and
    > 0 at 1 for 0 < r < 1, with one root in between (tavares.md section 5)."""
    c = 2.0 * gamma
    return optimize.brentq(lambda D: D - (c / (c - 5.0 * D + 5.0) * r) ** (c / 5.0), 0.0, 1.0,
                           xtol=1e-15)


def ref_t10(A, b_prime, ratio):
    """Eqs 7-8: t10 = A [1 - exp(-b' x)] with x = Ek/E50b (eq 7) or kappa Ek'/(m E) (eq 8)."""
    return A * (1.0 - math.exp(-b_prime * ratio))


def ref_tn(t10, alpha, beta):
    """Eq 10: t_n = 100 I(t10/100; alpha_n, beta_n), I the regularised incomplete beta."""
    return 100.0 * special.betainc(alpha, beta, t10 / 100.0)


def ref_lambda(t10, pairs):
    """Eq 12: lambda = ln(t4/t75) / ln(75/4) (pairs: dict n -> (alpha, beta))."""
    t4 = ref_tn(t10, *pairs[4.0])
    t75 = ref_tn(t10, *pairs[75.0])
    return math.log(t4 / t75) / math.log(75.0 / 4.0)


def pairs_of(mat):
    return dict(zip(N_ORDER, zip(mat.alpha_n, mat.beta_n)))


def ref_curve(t10, pairs, x):
    """Eq 10 through its t_n points, straight between them in log-log axes, and below d/75 the
    Gaudin-Schuhmann line t75 (75 x)^lambda with eq 12's slope (tavares.md section 11 step 2)."""
    sizes = [1.0] + [1.0 / n for n in (1.2, 1.5, 2.0, 4.0, 10.0, 25.0, 50.0, 75.0)]
    passing = [100.0] + [ref_tn(t10, *pairs[n]) for n in (1.2, 1.5, 2.0, 4.0)] + [t10] + [
        ref_tn(t10, *pairs[n]) for n in (25.0, 50.0, 75.0)]
    if x < 1.0 / 75.0:
        return passing[-1] * (75.0 * x) ** ref_lambda(t10, pairs)
    for (x0, p0), (x1, p1) in zip(zip(sizes, passing), zip(sizes[1:], passing[1:])):
        if x1 <= x <= x0:
            w = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0))
            return math.exp(math.log(p0) + w * (math.log(p1) - math.log(p0)))
    raise ValueError(x)


def on_steel(mat, d):
    """(absorbed share on steel by eq 4, median E50 by eq 3, Emax) of a particle of size d."""
    E50 = ref_E50(mat, d)
    return ref_share(hertz_k(mat.young, mat.poisson), K_STEEL), E50, mat.Emax_over_E50 * E50


def family_products(mat, t10_prime):
    """(product t10 of each family, its probability) of one particle broken with eq 8's t10': the
    family table at the tabulated t10' nearest to it and the d/10 share of its dummies (eq 11)."""
    return _family_products(mat, progeny_families.t10_grid(min(max(t10_prime, tv.T10_STEP),
                                                                mat.A)))


@functools.cache
def _family_products(mat, t10):
    table = progeny_families.families(mat, t10)
    return (100.0 * table.fractions[:, -1] * float(tv.fines_passing(t10, 0.1, mat)),
            table.probabilities / table.probabilities.sum())
