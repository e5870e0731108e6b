"""Stirred-mill power-draw calibration (seed 004 section 4.1).

Three stages, each a pure function over case files and a reference table, each a Snakemake rule
calling ``millsim analyse stirred-mill STAGE`` (``millsim analyse stirred-mill --help``):

1. ``friction``: dry cases (eta = 0) over friction x rpm; sum over rpm of squared residuals
   against the reference dry power; mu = the grid minimum (plus a parabola-refined estimate).
2. ``viscosity``: cases at the chosen mu and one speed over a grid of simulation viscosities; per
   fluid, the squared residual against the reference power at that speed; eta_sim = the grid
   minimum (plus the viscosity at which the simulated power, interpolated in log eta, equals the
   reference: the refined estimate; extrapolated from the nearest segment, and flagged, when the
   grid does not bracket it).
3. ``predict``: cases at the chosen mu and each fluid's eta_sim over all speeds, against the
   reference curves (seed Fig. 7).

Reference table (CSV, ``config/reference/stirred_mill_power.csv``): columns rpm [min-1], fluid
(``dry`` for the dry benchmark), eta_exp [Pa s], net_power [W], source.
"""

import math

import numpy as np
import pandas as pd

from ..io import case_parameters, read_case, read_table

REFERENCE_COLUMNS = ("rpm", "fluid", "eta_exp", "net_power", "source")
DRY = "dry"


def read_reference(path):
    """The reference power table, checked: required columns, numbers, a dry benchmark."""
    ref = read_table(path, comment="#")
    missing = [c for c in REFERENCE_COLUMNS if c not in ref.columns]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing}; need {list(REFERENCE_COLUMNS)}")
    for col in ("rpm", "eta_exp", "net_power"):
        ref[col] = pd.to_numeric(ref[col], errors="raise").astype(float)
    if (ref["rpm"] <= 0).any():
        raise ValueError(f"{path}: rpm must be > 0")
    if (ref["eta_exp"] < 0).any():
        raise ValueError(f"{path}: eta_exp must be >= 0")
    ref["fluid"] = ref["fluid"].astype(str)
    return ref


def case_table(paths):
    """One row per case: friction, eta, rpm, net power and its 95% half-width, path."""
    rows = []
    for path in paths:
        ds = read_case(path, "stirred_mill")
        p = case_parameters(ds)
        rows.append(dict(friction=float(p["friction"]), eta=float(p["eta"]), rpm=float(p["rpm"]),
                         net_power=float(ds["net_power"]), net_power_ci=float(ds["net_power_ci"]),
                         energy_balance_error=float(ds["energy_balance_error"]), case=str(path)))
    if not rows:
        raise ValueError("cases: none given")
    return pd.DataFrame(rows)


def _match(ref, rpm):
    """Reference power at ``rpm`` (rows of one fluid), or NaN."""
    hit = ref.loc[np.isclose(ref["rpm"], rpm), "net_power"]
    return float(hit.mean()) if len(hit) else math.nan


def _parabola_min(x, y):
    """Vertex of the parabola through the grid minimum and its neighbours (clipped to them)."""
    k = int(np.argmin(y))
    if k == 0 or k == len(x) - 1:
        return float(x[k])
    a, b, _ = np.polyfit(x[k - 1:k + 2], y[k - 1:k + 2], 2)
    if a <= 0:
        return float(x[k])
    return float(np.clip(-b / (2 * a), x[k - 1], x[k + 1]))


def friction_ssr(table):
    """Sum over speeds of the squared residuals, per friction (from the stage 1 residual table)."""
    return (table.assign(sq=table["residual"] ** 2).groupby("friction")
            .agg(ssr=("sq", "sum"), speeds=("sq", "size")).reset_index())


def calibrate_friction(cases, ref):
    """Stage 1. Returns (residual table, summary per mu, choice dict)."""
    dry_ref = ref[ref["fluid"] == DRY]
    if dry_ref.empty:
        raise ValueError(f"reference: no rows with fluid = {DRY!r} (the dry benchmark of stage 1)")
    cases = cases[cases["eta"] == 0.0].copy()
    cases["reference"] = [_match(dry_ref, r) for r in cases["rpm"]]
    cases = cases.dropna(subset=["reference"])
    if cases.empty:
        raise ValueError("stage 1: no dry case at a speed of the reference")
    cases["residual"] = cases["net_power"] - cases["reference"]
    summary = friction_ssr(cases)
    mu = summary["friction"].to_numpy()
    ssr = summary["ssr"].to_numpy()
    choice = dict(friction=float(mu[np.argmin(ssr)]), friction_refined=_parabola_min(mu, ssr),
                  ssr_min=float(ssr.min()), speeds=sorted(cases["rpm"].unique().tolist()))
    return cases.sort_values(["friction", "rpm"]), summary, choice


def calibrate_viscosity(cases, ref, friction, rpm):
    """Stage 2 at one speed. Returns (residual table, choice dict per fluid)."""
    sel = cases[np.isclose(cases["friction"], friction) & np.isclose(cases["rpm"], rpm)
                & (cases["eta"] > 0)].sort_values("eta")
    if len(sel) < 2:
        raise ValueError(f"stage 2: need >= 2 wet cases at friction {friction} and {rpm:g} rpm")
    rows, choice = [], {}
    for fluid, fref in ref[ref["fluid"] != DRY].groupby("fluid", sort=True):
        target = _match(fref, rpm)
        if math.isnan(target):
            continue
        res = sel["net_power"].to_numpy() - target
        eta = sel["eta"].to_numpy()
        for e, p, ci, r in zip(eta, sel["net_power"], sel["net_power_ci"], res):
            rows.append(dict(fluid=fluid, eta_exp=float(fref["eta_exp"].iloc[0]), eta_sim=e,
                             rpm=rpm, net_power=p, net_power_ci=ci, reference=target, residual=r))
        k = int(np.argmin(res**2))
        # refined: where the power, linear in log eta between grid points, crosses the reference
        # (extrapolated from the end segment nearer the minimum when the grid does not bracket it)
        crossing = [a for a in range(len(eta) - 1) if res[a] * res[a + 1] <= 0]
        a = crossing[0] if crossing else min(max(k - 1, 0), len(eta) - 2)
        f = res[a] / (res[a] - res[a + 1]) if res[a] != res[a + 1] else 0.0
        refined = float(math.exp(math.log(eta[a]) + f * (math.log(eta[a + 1]) - math.log(eta[a]))))
        choice[fluid] = dict(eta_sim=float(eta[k]), eta_sim_refined=refined,
                             refined_extrapolated=not crossing,
                             eta_exp=float(fref["eta_exp"].iloc[0]), residual=float(res[k]))
    if not choice:
        raise ValueError(f"stage 2: no wet reference fluid has a power at {rpm:g} rpm")
    return pd.DataFrame(rows), choice


def predict(cases, ref, friction, etas):
    """Stage 3: simulated vs reference power over speed, per fluid (and dry)."""
    rows = []
    for fluid, eta in {DRY: 0.0, **etas}.items():
        fref = ref[ref["fluid"] == fluid]
        sel = cases[np.isclose(cases["friction"], friction) & np.isclose(cases["eta"], eta)]
        for _, c in sel.sort_values("rpm").iterrows():
            target = _match(fref, c["rpm"])
            rows.append(dict(fluid=fluid, eta_sim=eta, rpm=c["rpm"], net_power=c["net_power"],
                             net_power_ci=c["net_power_ci"], reference=target,
                             residual=c["net_power"] - target))
    return pd.DataFrame(rows)
