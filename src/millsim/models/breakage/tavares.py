"""Tavares (UFRJ) breakage model with sphere replacement (Tavares et al. 2021).

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
- families (Tavares and Chagas 2021): discrete, mass-conserving sets of spheres whose
  probability-weighted mean reproduces the t_n curve (``families``), and ``break_particle``, which
  draws one and places it inside the parent.

Choices where the paper text is ambiguous are documented in docs/tavares.md.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
import yaml
from numba import njit
from scipy import optimize, special

from ...util import safe_yaml
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


# ---- the materials file (docs/materials.md) --------------------------------------------------
MATERIALS_FILE = "config/materials.yaml"
TRUNCATIONS = ("single_particle", "bed")
DEVICE_MATERIAL = "steel"  # what the scenes' balls, plates, anvils and strikers are made of
# Every key the file may hold; any other is refused, so that a misspelt key cannot silently
# leave a default in place.
TOP_KEYS = ("model", "materials", "contacts")
MODEL_KEYS = ("emax_over_e50", "device_surface", "E_inf_basis", "kappa", "kappa_placement",
              "family_tn", "family_classes", "fines_lambda", "e_min_J_per_kg")
_MODEL_DEFAULTS = MODEL_KEYS[2:]  # defaults of every material; a material's own value wins
_ELASTIC = ("density_kg_m3", "young_GPa", "poisson")
_REQUIRED_BREAKAGE = ("E_inf", "d0_mm", "phi", "sigma", "gamma", "A_percent", "b_prime",
                      "incomplete_beta")
MATERIAL_KEYS = ("source", "breakable", *_ELASTIC, *_REQUIRED_BREAKAGE, "Emax_over_E50",
                 *_MODEL_DEFAULTS)
DEVICE_KEYS = ("young_GPa", "poisson")
CONTACT_PAIRS = ("particle_steel", "particle_particle", "steel_steel")
CONTACT_KEYS = ("static_friction", "rolling_friction", "restitution")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_TN_NAMES = ("t1.2", "t1.5", "t2", "t4", "t10", "t25", "t50", "t75")


def _range(lo, hi, lo_open, hi_open):
    left = "(" if lo_open or lo is None else "["
    right = ")" if hi_open or hi is None else "]"
    lo = "-inf" if lo is None else f"{lo:g}"
    hi = "inf" if hi is None else f"{hi:g}"
    return f"{left}{lo}, {hi}{right}"


def _num(where, value, lo=None, hi=None, lo_open=True, hi_open=False):
    """A finite float within bounds, else a one-line ValueError naming ``where`` and the range."""
    x = None if isinstance(value, bool) else value
    try:
        x = float(x)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: must be a number, got {value!r}") from None
    bad = not math.isfinite(x) or (lo is not None and (x <= lo if lo_open else x < lo)) or (
        hi is not None and (x >= hi if hi_open else x > hi))
    if bad:
        raise ValueError(f"{where}: {x:g} is outside the allowed range "
                         f"{_range(lo, hi, lo_open, hi_open)}")
    return x


def _choice(where, value, allowed):
    if value not in allowed:
        raise ValueError(f"{where}: {value!r} is not one of {', '.join(allowed)}")
    return value


def _mapping(where, entry, known, required=()):
    """``entry`` as a mapping holding only ``known`` keys and every ``required`` one; ``where``
    is "FILE: block" (or "FILE:" for the top level)."""
    if not isinstance(entry, dict):
        raise ValueError(f"{where.rstrip(':')}: expected a mapping of keys, got {entry!r}")
    at = f"{where} " if where.endswith(":") else f"{where}."
    for key in entry:
        if key not in known:
            raise ValueError(f"{at}{key}: unknown key; known: {', '.join(known)}")
    for key in required:
        if key not in entry:
            raise ValueError(f"{at}{key}: missing (required: {', '.join(required)})")
    return entry


def _energy(where, entry):
    """E_inf given as {J_per_kg: x} or {kWh_per_t: x} (converted here, at the edge)."""
    if isinstance(entry, dict) and len(entry) == 1:
        (unit, value), = entry.items()
        if unit == "J_per_kg":
            return _num(f"{where}.J_per_kg", value, 0.0)
        if unit == "kWh_per_t":
            return _num(f"{where}.kWh_per_t", value, 0.0) * KWH_PER_T
    raise ValueError(f"{where}: give exactly one of {{J_per_kg: x}} or {{kWh_per_t: x}}, x > 0")


def _beta_pairs(where, entry):
    """Seven (alpha, beta) pairs keyed by n (all of N_VALUES, nothing else)."""
    if not isinstance(entry, dict):
        raise ValueError(f"{where}: expected a mapping n -> [alpha, beta]")
    byn = {}
    for key, pair in entry.items():
        n = _num(f"{where} key", key, 1.0)
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise ValueError(f"{where}.{key}: expected [alpha, beta], got {pair!r}")
        byn[n] = (_num(f"{where}.{key}[0] (alpha)", pair[0], 0.0),
                  _num(f"{where}.{key}[1] (beta)", pair[1], 0.0))
    if set(byn) != set(N_VALUES):
        want, got = (", ".join(f"{n:g}" for n in ns) for ns in (N_VALUES, sorted(byn)))
        raise ValueError(f"{where}: needs exactly n = {want}, got n = {got}")
    return tuple(byn[n] for n in N_VALUES)


def _options(where, e):
    """TavaresMaterial fields of the optional keys of ``e`` (a material, or `model`'s defaults)."""
    out = {}
    if "Emax_over_E50" in e:
        out["Emax_over_E50"] = _num(f"{where}.Emax_over_E50", e["Emax_over_E50"], 1.0)
    if "E_inf_basis" in e:
        out["E_inf_basis"] = _choice(f"{where}.E_inf_basis", e["E_inf_basis"], ENERGY_BASES)
    if "kappa" in e:
        out["kappa"] = _num(f"{where}.kappa", e["kappa"], 0.0)
    if "kappa_placement" in e:
        out["kappa_placement"] = _choice(f"{where}.kappa_placement", e["kappa_placement"],
                                         KAPPA_PLACEMENTS)
    if "family_tn" in e:
        out["family_tn"] = _choice(f"{where}.family_tn", e["family_tn"], FAMILY_TN)
    if "family_classes" in e:
        k = _num(f"{where}.family_classes", e["family_classes"], 1, 20, lo_open=False)
        if not k.is_integer():
            raise ValueError(f"{where}.family_classes: must be an integer in [1, 20], got {k:g}")
        out["family_classes"] = int(k)
    if "fines_lambda" in e:  # null: eq 12's slope from t4 and t75
        lam = e["fines_lambda"]
        out["fines_lambda"] = None if lam is None else _num(f"{where}.fines_lambda", lam, 0.0)
    if "e_min_J_per_kg" in e:
        out["e_min"] = _num(f"{where}.e_min_J_per_kg", e["e_min_J_per_kg"], 0.0, lo_open=False)
    return out


def _tn_order(where, mat):
    """The t_n of eq 10 must fall with n (t1.2 >= t1.5 >= ... >= t75) at every t10 in (0, A]."""
    t10, over = _tn_crossings(mat.tn_params, mat.A)
    if over.any():
        j = int(np.flatnonzero(over.any(axis=0))[0])
        bad = t10[over[:, j]]
        raise ValueError(f"{where}.incomplete_beta: {_TN_NAMES[j + 1]} > {_TN_NAMES[j]} for "
                         f"t10 in [{bad.min():.3g}, {bad.max():.3g}] %; eq 10 needs "
                         f"{' >= '.join(_TN_NAMES)} at every t10 in (0, A_percent]")


def _material(where, name, e, defaults, ks):
    """One material (Emax_over_E50 left to the truncation unless the material sets it)."""
    _mapping(where, e, MATERIAL_KEYS, _ELASTIC)
    breakable = e.get("breakable", True)
    if not isinstance(breakable, bool):
        raise ValueError(f"{where}.breakable: must be true or false, got {breakable!r}")
    kw = {"name": name,
          "density": _num(f"{where}.density_kg_m3", e["density_kg_m3"], 0.0),
          "young": _num(f"{where}.young_GPa", e["young_GPa"], 0.0) * 1e9,
          "poisson": _num(f"{where}.poisson", e["poisson"], 0.0, 0.5, lo_open=False, hi_open=True),
          "source": str(e.get("source", "")), "device_stiffness": ks}
    if not breakable:
        for key in e:
            if key not in ("source", "breakable", *_ELASTIC):
                raise ValueError(f"{where}.{key}: not a key of a material with breakable: false "
                                 f"(it never breaks); known: source, breakable, "
                                 f"{', '.join(_ELASTIC)}")
        return TavaresMaterial(**kw)
    for key in _REQUIRED_BREAKAGE:
        if key not in e:
            raise ValueError(f"{where}.{key}: missing (a breakable material needs "
                             f"{', '.join(_REQUIRED_BREAKAGE)}; or set breakable: false)")
    pairs = _beta_pairs(f"{where}.incomplete_beta", e["incomplete_beta"])
    kw.update(
        E_inf=_energy(f"{where}.E_inf", e["E_inf"]),
        d0=_num(f"{where}.d0_mm", e["d0_mm"], 0.0) * 1e-3,
        phi=_num(f"{where}.phi", e["phi"], 0.0),
        sigma=_num(f"{where}.sigma", e["sigma"], 0.0, 10.0),
        gamma=_num(f"{where}.gamma", e["gamma"], 0.0),
        A=_num(f"{where}.A_percent", e["A_percent"], 0.0, 100.0),
        b_prime=_num(f"{where}.b_prime", e["b_prime"], 0.0),
        alpha_n=tuple(a for a, _ in pairs), beta_n=tuple(b for _, b in pairs),
        **{**defaults, **_options(where, e)})
    mat = TavaresMaterial(**kw)
    _tn_order(where, mat)
    return mat


class _UniqueKeyLoader(safe_yaml.LimitedSafeLoader):
    """The bounded YAML loader (util.safe_yaml) that also refuses a repeated key: a copied
    material block left under its old name would otherwise replace the original without a word."""


class _DuplicateKey(ValueError):
    pass


def _unique_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=True)
        if key in seen:
            raise _DuplicateKey(f"line {key_node.start_mark.line + 1}: duplicate key {key!r}")
        seen.add(key)
    return loader.construct_mapping(node, deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _unique_mapping)


@functools.lru_cache(maxsize=16)
def _parse(path, text):
    """({truncation: {name: TavaresMaterial}}, contacts) of the file ``path`` holding ``text``,
    checked as a whole; cached on the text, since every case of a study checks the same file."""
    try:
        doc = safe_yaml.load(text, path, _UniqueKeyLoader)
    except _DuplicateKey as exc:
        raise ValueError(f"{path}: {exc}") from None
    _mapping(f"{path}:", doc, TOP_KEYS, TOP_KEYS)
    model = _mapping(f"{path}: model", doc["model"], MODEL_KEYS,
                     ("emax_over_e50", "device_surface"))
    ratios = _mapping(f"{path}: model.emax_over_e50", model["emax_over_e50"], TRUNCATIONS,
                      TRUNCATIONS)
    ratios = {t: _num(f"{path}: model.emax_over_e50.{t}", ratios[t], 1.0) for t in TRUNCATIONS}
    dev = _mapping(f"{path}: model.device_surface", model["device_surface"], DEVICE_KEYS,
                   DEVICE_KEYS)
    ks = stiffness(_num(f"{path}: model.device_surface.young_GPa", dev["young_GPa"], 0.0) * 1e9,
                   _num(f"{path}: model.device_surface.poisson", dev["poisson"], 0.0, 0.5,
                        lo_open=False, hi_open=True))
    defaults = _options(f"{path}: model", {k: model[k] for k in _MODEL_DEFAULTS if k in model})
    materials = doc["materials"]
    if not isinstance(materials, dict):
        raise ValueError(f"{path}: materials: expected a mapping name -> material")
    mats = {}
    for name, entry in materials.items():
        if not (isinstance(name, str) and _NAME.fullmatch(name)):
            raise ValueError(f"{path}: materials.{name!r}: a name is a letter followed by "
                             f"letters, digits or _ (it becomes part of the case paths)")
        mats[name] = _material(f"{path}: materials.{name}", name, entry, defaults, ks)
    if DEVICE_MATERIAL not in mats:
        raise ValueError(f"{path}: materials.{DEVICE_MATERIAL}: missing (balls, plates, anvils "
                         f"and strikers of the scenes are {DEVICE_MATERIAL})")
    by_truncation = {t: {name: mat if not mat.breakable or "Emax_over_E50" in materials[name]
                         else dataclasses.replace(mat, Emax_over_E50=ratios[t])
                         for name, mat in mats.items()} for t in TRUNCATIONS}
    contacts = _mapping(f"{path}: contacts", doc["contacts"], CONTACT_PAIRS, CONTACT_PAIRS)
    for pair in CONTACT_PAIRS:
        where = f"{path}: contacts.{pair}"
        c = _mapping(where, contacts[pair], CONTACT_KEYS, CONTACT_KEYS)
        _num(f"{where}.static_friction", c["static_friction"], 0.0, lo_open=False)
        _num(f"{where}.rolling_friction", c["rolling_friction"], 0.0, lo_open=False)
        _num(f"{where}.restitution", c["restitution"], 0.0, 1.0)
    return by_truncation, contacts


def _resolve(path):
    p = Path(path)
    if not p.is_absolute() and not p.exists():
        repo = Path(__file__).resolve().parents[4] / p  # src/millsim/models/breakage -> repo root
        if repo.exists():
            return repo
    return p


def _checked(path):
    path = _resolve(path)
    try:
        safe_yaml.check_size(path)
        text = path.read_text()
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: materials file not found") from None
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the materials file ({exc.strerror})") from None
    return _parse(str(path), text)


def check_materials_file(path=MATERIALS_FILE):
    """Check the materials file ``path`` as a whole; return its breakable materials (sorted).

    Every key known and every required one present, physical ranges, the t_n of eq 10 in order,
    a `steel` material and the Table 6 contacts: a bad file is refused with one line naming the
    file, the material (or block), the key and its allowed range (docs/materials.md).
    """
    mats, _ = _checked(path)
    return sorted(name for name, mat in mats["bed"].items() if mat.breakable)


def check_material(path, name):
    """The scenes' check of parameter ``material``: a breakable material of the file ``path``."""
    mats = _checked(path)[0]["bed"]
    known = ", ".join(sorted(n for n, m in mats.items() if m.breakable))
    if name not in mats:
        raise ValueError(f"material: {name!r} not in {path}; known: {known}")
    if not mats[name].breakable:
        raise ValueError(f"material: {name!r} never breaks (breakable: false in {path}); "
                         f"breakable: {known}")


def load_materials(path=MATERIALS_FILE, truncation="bed"):
    """Materials of ``path`` as {name: TavaresMaterial}, converted to SI.

    ``truncation`` picks Emax/E50 from ``model.emax_over_e50``: "single_particle" (4,
    Tavares et al. 2021 single-particle verification) or "bed" (100, the paper's bed validation;
    nearly untruncated, as the Table 4 fits were); a material's own ``Emax_over_E50`` overrides
    both. Errors name the file and the offending key (check_materials_file).
    """
    _choice("truncation", truncation, TRUNCATIONS)
    return dict(_checked(path)[0][truncation])


def load_contacts(path=MATERIALS_FILE):
    """The ``contacts`` table of the materials file (Tavares et al. 2021, Table 6): pair -> key ->
    value."""
    return {pair: dict(c) for pair, c in _checked(path)[1].items()}


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


def fines_passing(t10, x_rel, mat_or_params, x_min=SIEVE_RATIO**-STANDARD_CLASSES,
                  fines_lambda=None):
    """Eq 11: B(x) = (x/x_min)^lambda, the fraction of an event's unresolved fines below x_rel.

    B(x_min) = 1; the fines mass is the family's dummy share, so the event's passing below x_min
    is dummy_share * B(x).
    """
    lam = fines_exponent(t10, mat_or_params, fines_lambda)
    x = np.clip(np.asarray(x_rel, dtype=float), 0.0, None)
    return np.minimum((x / x_min) ** lam, 1.0)


def event_passing(t10, x_rel, mat_or_params, x_min=SIEVE_RATIO**-STANDARD_CLASSES,
                  fines_lambda=None):
    """Modelled % passing of one replacement event: eq 10 curve above x_min, eq 11 below it."""
    x = np.asarray(x_rel, dtype=float)
    above = cumulative_passing(t10, x, mat_or_params, fines_lambda)
    pmin = cumulative_passing(t10, x_min, mat_or_params, fines_lambda)
    below = pmin * fines_passing(t10, x, mat_or_params, x_min, fines_lambda)
    return np.where(x >= x_min, above, below)


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


# ---- placement of progeny inside the parent -------------------------------------------------
def _unit_ball_points(n=384):
    """Deterministic quasi-uniform points in the unit ball (golden-angle spiral, cube-root radii)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    rho = np.sqrt(1.0 - z * z)
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    dirs = np.stack([z, rho * np.cos(phi), rho * np.sin(phi)], axis=1)
    radial = ((i * 0.6180339887498949) % 1.0) ** (1.0 / 3.0)
    pts = dirs * radial[:, None]
    return np.vstack([np.zeros((1, 3)), dirs, pts])


_BALL = _unit_ball_points()  # columns: (along stress, across 1, across 2)


def _frame(direction, spin):
    """Orthonormal rows (s, e1, e2), e1/e2 turned by 2 pi spin about the stress direction s."""
    s = np.asarray(direction, dtype=float).reshape(3)
    norm = np.linalg.norm(s)
    s = s / norm if norm > 0 else np.array([0.0, 0.0, 1.0])
    a = np.array([1.0, 0.0, 0.0]) if abs(s[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = a - (a @ s) * s
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(s, e1)
    t = 2.0 * math.pi * spin
    return np.array([s, math.cos(t) * e1 + math.sin(t) * e2, -math.sin(t) * e1 + math.cos(t) * e2])


def place_fragments(radii, relax=40):
    """Centres (local frame, column 0 along the stress) of spheres of ``radii`` in a unit sphere.

    Largest first, each at the candidate position of least squared overlap with those placed,
    plus a bias: fragments larger than 0.3 of the parent radius avoid the stress axis (the
    split opens across the load, Fig 6 of Tavares et al. 2021) and smaller ones lean towards it
    (fines form near the loading points). Then a few relaxation sweeps push overlapping pairs apart,
    the smaller sphere moving more, always projected back inside.
    """
    r = np.asarray(radii, dtype=float)
    n = len(r)
    c = np.zeros((n, 3))
    for i in range(n):
        cand = _BALL * (1.0 - r[i])
        score = (r[i] - 0.3) * 0.5 * cand[:, 0] ** 2
        if i:
            dist = np.linalg.norm(cand[:, None, :] - c[None, :i, :], axis=2)
            score = score + (np.clip(r[i] + r[None, :i] - dist, 0.0, None) ** 2).sum(1)
        c[i] = cand[int(np.argmin(score))]
    vol = r**3
    iu, ju = np.triu_indices(n, 1)
    for _ in range(relax if n > 1 else 0):
        d = c[ju] - c[iu]
        dist = np.linalg.norm(d, axis=1)
        ov = r[iu] + r[ju] - dist
        hit = ov > 1e-12
        if not hit.any():
            break
        u = np.where(dist[:, None] > 1e-12, d / np.maximum(dist, 1e-12)[:, None],
                     np.array([0.0, 1.0, 0.0]))
        share_i = vol[ju] / (vol[iu] + vol[ju])
        move = np.zeros_like(c)
        np.add.at(move, iu[hit], -(0.5 * ov * share_i)[hit, None] * u[hit])
        np.add.at(move, ju[hit], (0.5 * ov * (1.0 - share_i))[hit, None] * u[hit])
        c += move
        lim = 1.0 - r
        norm = np.linalg.norm(c, axis=1)
        out = norm > lim
        c[out] *= (lim[out] / norm[out])[:, None]
    return c


# ---- the replacement step -------------------------------------------------------------------
class Progeny(NamedTuple):
    """Result of one breakage, parent-centred and in SI.

    offsets (k, 3) [m] and radii (k,) [m] of the spheres, largest first, dummies last; breakable
    (k,) bool: may break again (False for dummy spheres and resolved-unbreakable sizes);
    dummy (k,) bool: sphere stands for unresolved fines (never breaks; eq 11 afterwards);
    fines_mass [kg]: fines not put into spheres (dummy_as="fines"); t10: grid t10' [%] used;
    family: index of the family drawn; n_classes: resolved classes of that table.
    """

    offsets: np.ndarray
    radii: np.ndarray
    breakable: np.ndarray
    dummy: np.ndarray
    fines_mass: float
    t10: float
    family: int
    n_classes: int


def break_particle(mat, d_parent, specific_energy, fracture_energy, stress_direction, u_family,
                   u_spin, *, d_min=0.0, policy="standard", dummy_as="spheres"):
    """Replace a broken particle by one family of progeny spheres.

    mat, d_parent [m]; specific_energy: absorbed Ek'/m_p of the event [J/kg]; fracture_energy:
    the particle's current (damaged) E [J/kg] (together eq 8's t10'); stress_direction: unit
    vector of the breaking load; u_family, u_spin: the engine's uniforms in [0, 1) choosing the
    family and the arrangement's turn about the load axis; d_min [m]: global minimum resolved
    size; policy: see ``family_classes_for``; dummy_as: "spheres" (Tavares et al. 2021: dummy
    spheres of size x_min that never break) or "fines" (their mass is returned as fines_mass
    instead). Everything is deterministic in the arguments. Mass: sum of sphere masses + fines_mass
    equals the parent mass to round-off.
    """
    mat.require_breakage()
    if dummy_as not in ("spheres", "fines"):
        raise ValueError(f"dummy_as: {dummy_as!r} is not 'spheres' or 'fines'")
    K = family_classes_for(mat, d_parent, d_min, policy)
    if K == 0:
        raise ValueError(f"break_particle: a {d_parent:g} m particle is resolved-unbreakable "
                         f"with d_min = {d_min:g} m (policy {policy!r})")
    t10 = float(np.clip(t10_prime(mat, specific_energy, fracture_energy), T10_STEP, mat.A))
    table = families(mat, t10, K)
    cum = np.cumsum(table.probabilities)
    f = int(min(np.searchsorted(cum, float(u_family) * cum[-1], side="right"), len(cum) - 1))
    d_res = table.diameters[f]
    nd = int(table.dummy_counts[f])
    d_dum = float(table.dummy_diameter[f])
    fines_mass = 0.0
    if dummy_as == "fines":
        fines_mass = mat.density * math.pi / 6.0 * d_parent**3 * nd * d_dum**3
        nd = 0
    rel = np.concatenate([d_res, np.full(nd, d_dum)])
    local = place_fragments(rel)  # x/d of a diameter is also r/R of the radius
    R = 0.5 * d_parent
    frame = _frame(stress_direction, float(u_spin))
    offsets = (local @ frame) * R
    radii = rel * R
    dummy = np.arange(len(rel)) >= len(d_res)
    sizes = 2.0 * radii
    ok = np.array([family_classes_for(mat, s, d_min, policy) > 0 for s in sizes], dtype=bool)
    breakable = ok & ~dummy
    return Progeny(offsets, radii, breakable, dummy, fines_mass, table.t10, f, K)


def global_min_size(top_size, ratio=0.05):
    """d_min [m]: Tavares et al. 2021 set it to 1/20 of the top particle size in the simulation."""
    return float(top_size) * ratio


__all__ = [
    "KWH_PER_T",
    "N_VALUES",
    "SIEVE_RATIO",
    "STANDARD_CLASSES",
    "STEEL_STIFFNESS",
    "T10_STEP",
    "TABLE1_AVERAGE",
    "FamilyTable",
    "Progeny",
    "TavaresMaterial",
    "absorbed_share_of_test_energy",
    "break_particle",
    "class_targets",
    "cumulative_passing",
    "damage_fraction",
    "damaged_energy",
    "energy_share",
    "event_passing",
    "families",
    "family_classes_for",
    "fines_exponent",
    "fines_passing",
    "fracture_energy_cdf",
    "generate_families",
    "global_min_size",
    "is_breakable",
    "check_material",
    "check_materials_file",
    "load_contacts",
    "load_materials",
    "median_fracture_energy",
    "place_fragments",
    "resolved_unbreakable_passing",
    "sample_fracture_energy",
    "stiffness",
    "t10_grid",
    "t10_min",
    "t10_population",
    "t10_prime",
    "t_n",
    "tn_ordering_violations",
    "truncated_lognormal_cdf",
    "truncated_lognormal_ppf",
]
