"""The materials file of the Tavares model (config/materials.yaml, docs/materials.md).

Read and checked as a whole: every key known and every required one present, physical ranges,
the t_n of eq 10 (Tavares et al. 2021) in order, a `steel` material and the contacts of Table 6 of
Tavares et al. 2021. A bad file is refused with one line naming the file, the material (or block),
the key and its allowed range. Values are converted to SI here, at the edge, into
``tavares.TavaresMaterial``; E_inf may be given in kWh/t.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
from pathlib import Path

import numpy as np
import yaml

from ...util import safe_yaml
from .tavares import (
    ENERGY_BASES,
    FAMILY_TN,
    KAPPA_PLACEMENTS,
    KWH_PER_T,
    N_VALUES,
    TavaresMaterial,
    _choice,
    _tn_crossings,
    stiffness,
)

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
        # one class cannot hold a family: its fragment (2^(-3/4) of the volume) leaves less than
        # one dummy sphere, so the family would be the parent again (docs/tavares.md section 8)
        k = _num(f"{where}.family_classes", e["family_classes"], 2, 20, lo_open=False)
        if not k.is_integer():
            raise ValueError(f"{where}.family_classes: must be an integer in [2, 20], got {k:g}")
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
