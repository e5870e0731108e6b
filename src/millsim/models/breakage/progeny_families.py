"""Families of progeny spheres of the Tavares model (Tavares et al. 2021, section 2.2; Tavares
and Chagas 2021), and which parents are resolved enough to break.

A family is a discrete, mass-conserving set of spheres on the fourth-root-of-2 series (Table 2 of
Tavares et al. 2021) plus dummy spheres for the fines; the probabilities of a table of families
make their mean reproduce the size distribution of eqs 10-11 for one t10'. Tables are built per
t10' grid point (``T10_STEP``) and cached (``families``). ``family_classes_for`` and
``is_breakable`` apply the global minimum size d_min (section 2.3, ``global_min_size``).
"""

from __future__ import annotations

import functools
import math
import zlib
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from .tavares import (
    CUT_POLICIES,
    MIN_TRUNCATED_CLASSES,
    SIEVE_RATIO,
    STANDARD_CLASSES,
    T10_STEP,
    TABLE1_AVERAGE,
    _params,
    cumulative_passing,
)


# ---- families of progeny spheres ------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class FamilyTable:
    """Progeny families for one t10' (sizes relative to the parent diameter).

    edges: (K+1,) 1, 2^-1/4, ..., x_min; class k (1..K) holds fragments with diameter in
    [edges[k], edges[k-1]) and is nominally edges[k] (Tavares et al. 2021, Table 2 convention).
    target: (K+1,) class mass fractions of the eq 10 curve, last = dummy (below x_min).
    counts: (F, K) fragments per class; dummy_counts: (F,) dummy spheres.
    diameters: F arrays of resolved diameters (descending), dummy_diameter: (F,) diameter of the
    dummy spheres; every family has sum(d^3) + n_dummy d_dummy^3 = 1.
    fractions: (F, K+1) class mass fractions of each family; probabilities: (F,).
    """

    t10: float
    edges: np.ndarray
    target: np.ndarray
    counts: np.ndarray
    dummy_counts: np.ndarray
    diameters: tuple
    dummy_diameter: np.ndarray
    fractions: np.ndarray
    probabilities: np.ndarray

    @property
    def fit_error(self):
        """Largest |fitted - target| class mass fraction (round-off unless t10' < ~0.3 %)."""
        return float(np.abs(self.fitted - self.target).max())

    @property
    def fitted(self):
        """Probability-weighted mean class mass fractions (should equal ``target``)."""
        return self.probabilities @ self.fractions

    def passing(self, x_rel):
        """Probability-weighted mean % passing x_rel >= x_min from the actual sphere sizes.

        Dummy spheres stand for fines below x_min, so they pass every x >= x_min (below x_min
        use ``event_passing``, eq 11).
        """
        return 100.0 * (self.probabilities @ self.family_passing(x_rel))

    def family_passing(self, x_rel):
        """(F, len(x)) fraction of each family passing x_rel (>= x_min), dummies as fines."""
        x = np.atleast_1d(np.asarray(x_rel, dtype=float))
        out = np.zeros((len(self.probabilities), len(x)))
        for f, (d, nd, dd) in enumerate(zip(self.diameters, self.dummy_counts,
                                            self.dummy_diameter)):
            out[f] = (d[None, :] ** 3 * (d[None, :] < x[:, None])).sum(1) + nd * dd**3
        return out


def class_targets(t10, params, n_classes=STANDARD_CLASSES):
    """Sieve edges and mass fractions of classes [x_k, x_(k-1)), k = 1..K, plus the dummy."""
    edges = SIEVE_RATIO ** -np.arange(n_classes + 1.0)
    P = cumulative_passing(t10, edges, params) / 100.0
    return edges, np.append(P[:-1] - P[1:], P[-1])


def _close_family(n, edges, grow_largest=False):
    """Diameters of a family with counts n, mass closed exactly; None if it cannot be.

    Fragments start at their class's lower edge (Tavares et al. 2021, Table 2). The dummy gets as
    many spheres of size x_min as fit; the remainder (< x_min^3) goes to the largest fragments, each
    staying inside its own class, so the class fractions the probabilities are fitted to stay
    true; only if that is not enough do the dummy spheres grow. grow_largest: if the largest
    fragment is in the top class [x_1, 1), first let it take up to its whole class headroom and
    give the dummy only the rest. Low t10' needs such families (over 60 % of the mass in the top
    class); the top class holds no t_n sieve (1/1.2 < x_1), so growing there distorts no t_n.
    """
    K = len(n)
    xk = edges[1:]
    vol = xk**3
    vr = float(n @ vol)
    if vr > 1.0 + 1e-12:
        return None
    free = 1.0 - vr
    nd = math.floor(free / vol[-1] + 1e-9)
    cls = np.repeat(np.arange(1, K + 1), n)
    if grow_largest and len(cls) and cls[0] == 1:
        room = (edges[cls[0] - 1] ** 3 - vol[cls[0] - 1]) * (1.0 - 1e-6)
        nd = min(nd, max(0, math.ceil((free - room) / vol[-1] - 1e-9)))
    d = xk[cls - 1].copy()
    dd = xk[-1]
    gap = 1.0 - vr - nd * vol[-1]
    last = None
    for i in range(len(d)):
        if gap <= 0.0:
            break
        room = (edges[cls[i] - 1] ** 3 - d[i] ** 3) * (1.0 - 1e-6)
        take = min(gap, room)
        d[i] = (d[i] ** 3 + take) ** (1.0 / 3.0)
        gap -= take
        last = i
    if gap > 0.0:
        if nd == 0:
            return None
        dd = ((nd * dd**3 + gap) / nd) ** (1.0 / 3.0)
        last = None
    # close to round-off: solve the last adjusted size from all the others
    if last is not None:
        rest = float(np.sum(np.delete(d, last) ** 3) + nd * dd**3)
        d[last] = (1.0 - rest) ** (1.0 / 3.0)
    elif nd:
        dd = ((1.0 - float(np.sum(d**3))) / nd) ** (1.0 / 3.0)
    elif len(d):
        rest = float(np.sum(d[1:] ** 3))
        d[0] = (1.0 - rest) ** (1.0 / 3.0)
    return cls, d, nd, dd


def _candidates(w, vol, w_dummy, rng, per_kind):
    """Integer class counts n (rows), each fitting in the parent volume (sum n vol <= 1).

    Three kinds, vectorised over candidates: largest-first stochastic rounding of jittered
    expected counts with the rounding error carried to the next class, the same without carry,
    and random sequential filling (a class drawn in proportion to its expected number, kept if
    it fits, until the free volume falls to a jittered dummy share). Plus, for each class, one
    fragment of it and nothing else resolved, which keeps near-empty classes inside the hull.
    """
    K = len(w)
    out = [np.eye(K, dtype=np.int64)]
    for carry_on in (True, False):
        f = rng.uniform(0.5, 1.5, (per_kind, K))
        u = rng.random((per_kind, K))
        n = np.zeros((per_kind, K), dtype=np.int64)
        free = np.ones(per_kind)
        carry = np.zeros(per_kind)
        for k in range(K):
            want = w[k] * f[:, k] + carry
            nk = np.floor(np.maximum(want, 0.0) / vol[k] + u[:, k]).astype(np.int64)
            nk = np.minimum(nk, np.floor(free / vol[k] + 1e-9).astype(np.int64))
            n[:, k] = nk
            free -= nk * vol[k]
            carry = want - nk * vol[k] if carry_on else carry
        out.append(n)
    cum = np.cumsum((w / vol) / np.sum(w / vol))
    n = np.zeros((per_kind, K), dtype=np.int64)
    free = np.ones(per_kind)
    stop = w_dummy * rng.uniform(0.5, 1.5, per_kind)
    rows = np.arange(per_kind)
    for _ in range(int(2.0 / vol[-1]) + 10):
        active = (free > stop) & (free >= vol[-1] - 1e-12)
        if not active.any():
            break
        k = np.minimum(np.searchsorted(cum, rng.random(per_kind) * cum[-1], side="right"), K - 1)
        take = active & (vol[k] <= free + 1e-12)
        np.add.at(n, (rows[take], k[take]), 1)
        free[take] -= vol[k[take]]
    out.append(n)
    return np.unique(np.vstack(out), axis=0)


def _ro(a):
    """Read-only view for tables shared through the cache."""
    a.setflags(write=False)
    return a


def _fit_probabilities(F, target):
    """Family probabilities p >= 0, sum 1, with p @ F = target, favouring typical families.

    Among the exact mixtures, a linear programme picks the one of least mean squared distance
    between each family's cumulative distribution and the target, so the chosen families
    scatter closely around the curve (as Fig 2 of Tavares et al. 2021) instead of mixing extremes.
    A basic solution uses at most K + 1 families (the paper: "no more than 11 families"). If the
    target is outside the candidates' hull, non-negative least squares gives the closest mixture.
    """
    K = F.shape[1] - 1
    cum_f = np.cumsum(F[:, ::-1], axis=1)
    cum_t = np.cumsum(target[::-1])
    cost = ((cum_f - cum_t) ** 2).sum(1)
    A_eq = np.vstack([F[:, :K].T, np.ones(len(F))])
    b_eq = np.append(target[:K], 1.0)
    res = optimize.linprog(cost, A_eq=A_eq, b_eq=b_eq, bounds=(0.0, None), method="highs")
    if res.status == 0:
        return res.x
    weight = 10.0
    p, _ = optimize.nnls(np.vstack([F.T, weight * np.ones(len(F))]), np.append(target, weight),
                         maxiter=50 * len(F))
    return p


def generate_families(t10, params=TABLE1_AVERAGE, n_classes=STANDARD_CLASSES, per_kind=1000,
                      seed=None):
    """Build the family table for intensity t10 [%] (uncached; see ``families``).

    Candidates are mass-closed integer families (``_candidates``, ``_close_family``); their
    probabilities come from ``_fit_probabilities``. The RNG seed derives from the inputs, so a
    table is the same whenever and in whatever order it is built.
    """
    if n_classes < 2:  # its one fragment leaves less than a dummy: the family is the parent
        raise ValueError(f"families: n_classes must be at least 2, got {n_classes}")
    params = _params(params)
    edges, target = class_targets(t10, params, n_classes)
    if seed is None:
        seed = zlib.crc32(repr((round(float(t10), 9), params, n_classes)).encode())
    rng = np.random.default_rng(seed)
    vol = edges[1:] ** 3
    built = []
    for n in _candidates(target[:-1], vol, target[-1], rng, per_kind):
        a = _close_family(n, edges)
        b = _close_family(n, edges, grow_largest=True)
        for closed in (a,) if b is None or (a is not None and a[2] == b[2]) else (a, b):
            if closed is not None:
                built.append((n, *closed))
    K = n_classes
    F = np.zeros((len(built), K + 1))
    for j, (_, cls, d, nd, dd) in enumerate(built):
        np.add.at(F[j], cls - 1, d**3)
        F[j, K] = nd * dd**3
    p = _fit_probabilities(F, target)
    keep = np.flatnonzero(p > 1e-9)
    keep = keep[np.argsort(-p[keep], kind="stable")]
    p = p[keep] / p[keep].sum()
    sel = [built[j] for j in keep]
    return FamilyTable(
        t10=float(t10), edges=_ro(edges), target=_ro(target),
        counts=_ro(np.array([s[0] for s in sel])),
        dummy_counts=_ro(np.array([s[3] for s in sel], dtype=np.int64)),
        diameters=tuple(_ro(s[2]) for s in sel),
        dummy_diameter=_ro(np.array([s[4] for s in sel])),
        fractions=_ro(F[keep]), probabilities=_ro(p))


@functools.lru_cache(maxsize=4096)
def _cached_families(params, t10_key, n_classes):
    return generate_families(round(t10_key * T10_STEP, 9), params, n_classes)


def t10_grid(t10):
    """The tabulated t10' nearest to t10 (step T10_STEP, at least one step)."""
    return round(max(round(float(t10) / T10_STEP), 1) * T10_STEP, 9)


def families(mat, t10, n_classes=None):
    """Cached family table of ``mat`` for the grid t10' nearest to t10 (deterministic)."""
    n_classes = mat.family_classes if n_classes is None else n_classes
    key = max(round(float(t10) / T10_STEP), 1)
    return _cached_families(mat.family_params, key, int(n_classes))


# ---- resolved sizes and breakability --------------------------------------------------------
def family_classes_for(mat, d, d_min, policy="standard"):
    """Resolved classes a parent of size d [m] breaks into (0 = it cannot break).

    "standard": the full family (down to x_min = 0.21 d) must stay >= d_min, else the particle is
    resolved-unbreakable (Tavares et al. 2021: d_min is the smallest resolved size in
    the simulation). "truncate": the family is cut at d_min and the rest joins the dummy class; with
    fewer than MIN_TRUNCATED_CLASSES classes left (dummy spheres above half the parent) it cannot
    break.
    """
    K = mat.family_classes
    if d_min <= 0.0:
        return K
    fit = math.floor(4.0 * math.log2(d / d_min) + 1e-9)
    if policy == "standard":
        return K if fit >= K else 0
    if policy == "truncate":
        fit = min(fit, K)
        return fit if fit >= min(MIN_TRUNCATED_CLASSES, K) else 0
    raise ValueError(f"policy: {policy!r} is not one of {CUT_POLICIES}")


def is_breakable(mat, d, d_min, policy="standard"):
    """Whether a (non-dummy) particle of size d [m] may break and be replaced."""
    return mat.breakable and family_classes_for(mat, d, d_min, policy) > 0


def global_min_size(top_size, ratio=0.05):
    """d_min [m]: Tavares et al. 2021 set it to 1/20 of the top particle size in the simulation."""
    return float(top_size) * ratio
