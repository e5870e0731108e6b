"""Error against run time (work-precision) of each scene's headline observables.

A *ladder* is one scene run over a sequence of time steps (a `dt` or `dt_factor` sweep), each step
repeated over seeds. Per step and observable this module gives the mean over seeds, the error
against a converged reference, the statistical noise and the wall time, and picks the cheapest step
whose error is within a tolerance (1 % of the reference) or within the noise. Everything here is a
pure function of numbers (numpy/pandas); ``millsim analyse accuracy`` reads the case files and
writes ``results/aggregate/accuracy.nc``, ``millsim plot error_vs_runtime_<name>`` draws the figures
(millsim.plots.accuracy).

Definitions (also in docs/results/accuracy.md, "How the numbers are made"):

- **reference**: the converged value. ``finest``: the mean over seeds at the finest step of the
  series. ``richardson``: extrapolation to dt = 0 from the two finest steps with the observed
  order (three finest steps) or the nominal order 2. ``auto`` (default): Richardson when the
  observable converges smoothly, i.e. the three finest means are monotone, their differences are
  resolved (larger than twice their standard error) and the observed order lies in [0.5, 6];
  otherwise the finest step. ``exact``: the observable is itself a residual whose exact value is 0.
  A series may borrow the reference of another series of the same physics (Verlet against Gear).
- **error**: mean over seeds minus the reference, computed as the mean of the paired differences
  seed by seed (the same seed starts from the same state and draws the same fracture energies;
  a Richardson reference is extrapolated seed by seed). ``error_se``: the standard deviation of
  the paired differences pooled over the steps of the ladder, over sqrt(seeds). Where the seeds
  stay correlated (single particles) it is tiny; in chaotic mills it is about the noise x
  sqrt(2 / seeds).
- **noise**: the standard deviation over seeds of one case at the reference step (the scatter a
  single run of that size has); NaN with one seed.
- **within**: |error| <= max(tolerance x |reference|, 2 error_se): within the tolerance, or not
  distinguishable from zero by the seeds (for residuals the tolerance is absolute).
- **cheapest**: walking from the finest step towards coarser ones while every step is within,
  and among the steps at most ``limit_fraction`` of the engine's stability limit (a margin,
  configurable, 1 = none), the one with the fewest time steps (the cost of a case is its number
  of steps; the measured wall time, reported beside it, is the smallest over the seeds, since
  load from other jobs and the one-off kernel compile of the first case of a physics variant
  only ever add to it).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
import xarray as xr

import millsim

from .accuracy_output import points_frame, summary_markdown, to_dataset

__all__ = [
    "OBSERVABLES", "Observable", "observed_order", "richardson", "reference_value",
    "ladder_statistics", "error_table", "cheapest_within", "collect", "analyse", "study",
    "to_dataset", "points_frame", "summary_markdown",
]

NOMINAL_ORDER = 2.0  # velocity Verlet and Gear as used here are both second order globally
ORDER_RANGE = (0.5, 6.0)


# ---- observables --------------------------------------------------------------------------------

@dataclass(frozen=True)
class Observable:
    name: str
    units: str
    long_name: str
    extract: Callable[[xr.Dataset], float]
    headline: bool = True
    residual: bool = False  # exact value 0; the value is already relative


def _var(name):
    def get(ds):
        return float(ds[name]) if name in ds else math.nan
    return get


def _mean_absorbed(ds):
    """Mean over particles of the absorbed specific energy of the first stressing event.

    Paired between steps: the same seed gives the same particles the same fracture energies, so
    the difference between two steps is discretisation only (the loading-work quadrature and the
    overshoot of the step where a particle breaks)."""
    if "particle_absorbed_energy" not in ds:
        return math.nan
    return float(np.nanmean(ds["particle_absorbed_energy"].values))


def _passing_at(size):
    def get(ds):
        if "passing_fraction" not in ds:
            return math.nan
        sieve = ds["sieve"].values
        k = int(np.argmin(np.abs(sieve - size)))
        if not np.isclose(sieve[k], size, rtol=1e-6):
            return math.nan
        return float(ds["passing_fraction"].values[k])
    return get


OBSERVABLES: dict[str, tuple[Observable, ...]] = {
    "ballmill2d": (
        Observable("comminution_rate", "s-1", "steady-state comminution rate (fractures per s)",
                   _var("comminution_rate")),
        Observable("drive_power", "W", "steady-state mean drive power", _var("mean_drive_power")),
    ),
    "single_particle": (
        Observable("broken_fraction", "1", "fraction of particles broken (breakage probability)",
                   _var("broken_fraction")),
        Observable("absorbed_energy", "J kg-1",
                   "mean absorbed specific energy of the first stressing event (paired)",
                   _mean_absorbed),
        Observable("product_t10", "%", "t10 of the broken particles' product", _var("product_t10")),
    ),
    "bed_impact": (
        Observable("broken_mass", "kg", "broken mass (mass passing 4.75 mm)", _var("broken_mass")),
        Observable("passing_1180um", "1", "fraction of the bed passing 1.18 mm",
                   _passing_at(1.18e-3), headline=False),
    ),
    "stirred_mill": (
        Observable("net_power", "W", "steady-state mean net power", _var("net_power")),
        Observable("energy_balance_error", "1",
                   "energy-balance residual / agitator work (steady window)",
                   _var("energy_balance_error"), headline=False, residual=True),
    ),
}


def observable(scene, name):
    for obs in OBSERVABLES.get(scene, ()):
        if obs.name == name:
            return obs
    raise ValueError(f"observable: {name!r} is not one of scene {scene!r}: "
                     f"{[o.name for o in OBSERVABLES.get(scene, ())]}")


# ---- convergence: order, extrapolation, reference ----------------------------------------------

def observed_order(h, y):
    """Order p of y(h) = y0 + C h^p through three points (any spacing of h).

    Solves (y3 - y2) / (y2 - y1) = (h3^p - h2^p) / (h2^p - h1^p) for p, with the points sorted by
    h. NaN when the differences change sign (not monotone), a step repeats or no p in [0.05, 20]
    fits."""
    h = np.asarray(h, dtype=float)
    y = np.asarray(y, dtype=float)
    if h.size != 3 or y.size != 3 or not np.all(np.isfinite(np.r_[h, y])):
        return math.nan
    k = np.argsort(h)
    h, y = h[k], y[k]
    d1, d2 = y[1] - y[0], y[2] - y[1]
    if d1 == 0 or d2 == 0 or np.sign(d1) != np.sign(d2) or h[0] <= 0 or h[1] in (h[0], h[2]):
        return math.nan  # a repeated step has no order
    target = math.log(d2 / d1)

    def f(p):
        return math.log((h[2] ** p - h[1] ** p) / (h[1] ** p - h[0] ** p)) - target

    lo, hi = 0.05, 20.0
    flo, fhi = f(lo), f(hi)
    if flo * fhi > 0:
        return math.nan
    if flo == 0 or fhi == 0:  # the root at an end of the bracket (the bisection keeps neither)
        return lo if flo == 0 else hi
    for _ in range(200):  # bisection: f increases with p
        mid = 0.5 * (lo + hi)
        fm = f(mid)
        if fm == 0:
            return mid
        if (fm < 0) == (flo < 0):
            lo, flo = mid, fm
        else:
            hi = mid
    return 0.5 * (lo + hi)


def richardson(h, y, order=NOMINAL_ORDER):
    """Extrapolation to h = 0 from the two finest points: y1 + (y1 - y2) / ((h2/h1)^p - 1)."""
    h = np.asarray(h, dtype=float)
    y = np.asarray(y, dtype=float)
    k = np.argsort(h)[:2]
    (h1, h2), (y1, y2) = h[k], y[k]
    if not h2 > h1 > 0:
        raise ValueError("richardson: need two distinct positive steps")
    return float(y1 + (y1 - y2) / ((h2 / h1) ** order - 1.0))


def reference_value(h, mean, se=None, method="auto", diff_se=None):
    """The converged value of a ladder: dict(value, se, method, order, step, step2).

    ``h``: the steps, ``mean``: the mean over seeds at each, ``se``: its standard error (zeros if
    not given); ``diff_se``: standard errors of the differences between consecutive steps, finest
    first (paired over seeds; default: the two standard errors combined). ``method``: auto |
    finest | richardson | exact (see the module docstring). ``step`` (and ``step2``) are the
    steps the reference is taken from."""
    h = np.asarray(h, dtype=float)
    mean = np.asarray(mean, dtype=float)
    se = np.zeros_like(mean) if se is None else np.nan_to_num(np.asarray(se, dtype=float))
    ok = np.isfinite(mean) & np.isfinite(h)
    h, mean, se = h[ok], mean[ok], se[ok]
    none = dict(value=math.nan, se=math.nan, method="none", order=math.nan, step=math.nan,
                step2=math.nan)
    if method == "exact":
        return dict(none, value=0.0, se=0.0, method="exact", step=0.0)
    if h.size == 0:
        return none
    k = np.argsort(h)
    h, mean, se = h[k], mean[k], se[k]
    if diff_se is None or len(diff_se) != h.size - 1:
        diff_se = [math.hypot(se[j], se[j + 1]) for j in range(h.size - 1)]
    diff_se = np.nan_to_num(np.asarray(diff_se, dtype=float))
    finest = dict(none, value=float(mean[0]), se=float(se[0]), method="finest", step=float(h[0]))
    if method == "finest" or h.size < 2:
        return finest
    if method not in ("auto", "richardson"):
        raise ValueError(f"method: auto | finest | richardson | exact, got {method!r}")
    order = observed_order(h[:3], mean[:3]) if h.size >= 3 else math.nan
    good_order = bool(np.isfinite(order) and ORDER_RANGE[0] <= order <= ORDER_RANGE[1])
    smooth = (good_order and abs(mean[1] - mean[0]) > 2 * diff_se[0]
              and abs(mean[2] - mean[1]) > 2 * diff_se[1])
    if method == "auto" and not smooth:
        return finest
    p = order if good_order else NOMINAL_ORDER
    g = 1.0 / ((h[1] / h[0]) ** p - 1.0)
    value = richardson(h[:2], mean[:2], p)
    return dict(value=value, se=float(math.hypot((1 + g) * se[0], g * se[1])), method="richardson",
                order=float(p), step=float(h[0]), step2=float(h[1]))


def seed_reference(values, reference):
    """The reference seed by seed (Series indexed by seed), for paired errors.

    finest: each seed's value at the reference step; richardson: each seed's own two finest
    values extrapolated with the reference's order (their mean is the reference of the means);
    exact: zeros."""
    seeds = np.unique(values["seed"])
    method = reference["method"]
    if method == "exact":
        return pd.Series(0.0, index=pd.Index(seeds, name="seed"))
    at = {h: values[values["step"] == h].set_index("seed")["value"]
          for h in (reference["step"], reference.get("step2", math.nan)) if np.isfinite(h)}
    if method == "finest":
        return at[reference["step"]]
    if method == "richardson":
        h1, h2 = reference["step"], reference["step2"]
        g = 1.0 / ((h2 / h1) ** reference["order"] - 1.0)
        return (at[h1] + g * (at[h1] - at[h2])).dropna()
    return pd.Series(dtype=float)


# ---- tables -------------------------------------------------------------------------------------

def ladder_statistics(values, wall_time=None):
    """Per step: n, mean, sd, se over seeds, and the wall time (the smallest over seeds).

    ``values``: DataFrame with columns step, seed, value (one row per case); ``wall_time``: the
    same rows' wall times (optional). Sorted by step, finest first."""
    df = values.copy()
    if wall_time is not None:
        df["wall_time"] = np.asarray(wall_time, dtype=float)
    g = df.groupby("step", sort=True)
    out = pd.DataFrame({
        "n": g["value"].count(),
        "mean": g["value"].mean(),
        "sd": g["value"].std(ddof=1),
    })
    out["se"] = out["sd"] / np.sqrt(out["n"])
    if "wall_time" in df:
        out["wall_time"] = g["wall_time"].min()
    return out.reset_index()


def _pooled_sd(groups):
    """Standard deviation pooled over groups (each a Series of samples): sqrt(sum of squared
    deviations from each group's mean / sum of (n - 1)); NaN without two samples in a group."""
    ss, dof = 0.0, 0
    for g in groups:
        g = g.dropna()
        if g.size > 1:
            ss += float(((g - g.mean()) ** 2).sum())
            dof += g.size - 1
    return math.sqrt(ss / dof) if dof else math.nan


def error_table(values, wall_time=None, tolerance=0.01, method="auto", residual=False,
                reference=None, reference_values=None):
    """Error against the converged reference at every step of one ladder (one observable).

    ``values``: DataFrame step, seed, value. ``reference``: a reference dict of
    :func:`reference_value` to use instead of this ladder's own (a series compared with another's
    converged value); ``reference_values``: that series' values (for the pairing and the noise).
    Errors are means of paired differences seed by seed against :func:`seed_reference`, so that
    what the seeds share (initial state, fracture energies) cancels. Returns (table per step,
    finest first; reference dict with the noise added)."""
    stats = ladder_statistics(values, wall_time)
    own = values if reference_values is None else reference_values
    if reference is None:
        steps = stats["step"].to_numpy()
        by_step = {h: values[values["step"] == h].set_index("seed")["value"] for h in steps}
        # differences between consecutive steps, paired over seeds; the smoothness test of
        # reference_value looks at the two finest, so their scatter is pooled over those two
        pairs = [by_step[h2] - by_step[h1] for h1, h2 in zip(steps[:-1], steps[1:])]
        sd = _pooled_sd(pairs[:2])
        diff_se = None
        if np.isfinite(sd):
            diff_se = [sd / math.sqrt(max(d.count(), 1)) for d in pairs]
        reference = reference_value(steps, stats["mean"], stats["se"],
                                    "exact" if residual else method, diff_se)
    reference = dict(reference)
    # noise: the single-case scatter at the finest step of the reference's series
    own_stats = ladder_statistics(own)
    reference["noise"] = float(own_stats["sd"].iloc[0]) if len(own_stats) else math.nan
    ref = reference["value"]
    scale = 1.0 if residual else abs(ref)
    ref_side = seed_reference(own, reference)
    diffs = {}
    for h in stats["step"]:
        here = values[values["step"] == h].set_index("seed")["value"]
        diffs[h] = (here - ref_side).dropna()
    # the scatter of the paired differences, pooled over the ladder (the reference step of a
    # finest-step reference, zero by construction, left out): a few seeds per step give a poor
    # standard error each, the pool a usable one
    same = reference["method"] == "finest" and reference_values is None
    pooled = _pooled_sd([d for h, d in diffs.items() if not (same and h == reference["step"])])
    rows = []
    for _, r in stats.iterrows():
        d = diffs[r["step"]]
        if d.size:
            err = float(d.mean())
            se = 0.0 if same and r["step"] == reference["step"] else pooled / math.sqrt(d.size)
        else:  # no common seeds: unpaired
            err = r["mean"] - ref
            se = math.hypot(np.nan_to_num(r["se"]), np.nan_to_num(reference["se"]))
        # within the tolerance, or not distinguishable from zero (two standard errors)
        tol = tolerance * scale
        if np.isfinite(se):
            tol = max(tol, 2 * se)
        rows.append(dict(step=r["step"], n=int(r["n"]), mean=r["mean"], sd=r["sd"],
                         error=err, error_se=se,
                         relative_error=err / scale if scale > 0 else math.nan,
                         relative_error_se=se / scale if scale > 0 else math.nan,
                         tolerance=tol, within=bool(abs(err) <= tol),
                         resolved=bool(np.isfinite(se) and abs(err) > 2 * se),
                         wall_time=r.get("wall_time", math.nan)))
    return pd.DataFrame(rows), reference


def cheapest_within(step, cost, within, contiguous=True):
    """Index of the cheapest acceptable step, or None.

    Acceptable: ``within`` true and, with ``contiguous``, every finer step within too (walking
    from the finest step, the first failure ends the search). Cheapest: smallest ``cost``; ties
    go to the larger step."""
    step = np.asarray(step, dtype=float)
    cost = np.asarray(cost, dtype=float)
    within = np.asarray(within, dtype=bool)
    order = np.argsort(step)
    ok = []
    for k in order:
        if not within[k]:
            if contiguous:
                break
            continue
        ok.append(k)
    if not ok:
        return None
    ok = np.array(ok)
    c = np.where(np.isfinite(cost[ok]), cost[ok], np.inf)
    best = ok[c == c.min()]
    return int(best[np.argmax(step[best])])


# ---- the study: cases -> tables ----------------------------------------------------------------

# the columns of collect's table, which the aggregate reads
TABLE_COLUMNS = ("name", "scene", "series", "ladder", "ladder_value", "seed", "dt", "dt_limit",
                 "steps", "wall_time_s", "engine_hash", "millsim_version", "parameters_json",
                 "path", "observable", "value", "units")


def collect(paths, name, series, ladder):
    """One row per (case, observable) of one series: the long table the aggregate reads."""
    from ..io import case_parameters, read_case

    rows = []
    for path in paths:
        ds = read_case(path, "*")
        a = ds.attrs
        scene = a["scene"]
        params = case_parameters(ds)
        if ladder not in params:
            raise ValueError(f"{path}: ladder {ladder!r} is not a parameter of scene {scene!r}")
        base = dict(name=name, scene=scene, series=series, ladder=ladder,
                    ladder_value=float(params[ladder]), seed=int(params["seed"]),
                    dt=float(a["dt"]), dt_limit=float(a.get("dt_limit", math.nan)),
                    steps=int(a["steps"]), wall_time_s=float(a["wall_time_s"]),
                    engine_hash=str(a.get("engine_hash", "")),
                    millsim_version=str(a.get("millsim_version", "")),
                    parameters_json=a["parameters_json"], path=str(path))
        for obs in OBSERVABLES.get(scene, ()):
            rows.append(dict(base, observable=obs.name, value=obs.extract(ds), units=obs.units))
    if not rows:
        raise ValueError("cases: none given")
    return pd.DataFrame(rows)


def read_tables(paths):
    """The tables of collect as one DataFrame; a file of another kind is refused, naming it."""
    from ..io import read_table

    tables = []
    for path in paths:
        table = read_table(path)
        missing = [c for c in TABLE_COLUMNS if c not in table.columns]
        if missing:
            raise ValueError(f"{path}: missing columns {missing}; not a table of `millsim analyse "
                             "accuracy collect`")
        tables.append(table)
    return pd.concat(tables, ignore_index=True)


def analyse(cases, tolerance=0.01, links=None, methods=None, decide=None, limit_fraction=1.0):
    """Points (per name, series, observable, step) and choices from the long case table.

    ``links``: {(name, series): other series of that name whose reference it uses};
    ``methods``: {name: reference method}; ``decide``: {name: observables that decide the
    default step} (default: the headline observables); ``limit_fraction``: a chosen step stays at
    or below this fraction of the engine's stability limit (a margin: particles created later or
    faster than declared make the limit a moving target). Steps are the series' ladder values;
    dt is the median actual step over seeds."""
    links, methods, decide = links or {}, methods or {}, decide or {}
    cases = cases[np.isfinite(cases["value"])]
    points, refs = [], {}
    keys = ["name", "series", "observable"]
    groups = {k: g for k, g in cases.groupby(keys, sort=False)}
    # own references first, then the series that borrow one
    order = sorted(groups, key=lambda k: (k[0], k[1]) in links)
    for key in order:
        name, series, obs_name = key
        g = groups[key]
        scene = g["scene"].iloc[0]
        obs = observable(scene, obs_name)
        # step = dt (finest first); the ladder value is carried along
        vals = g.assign(step=g["dt"])[["step", "seed", "value"]]
        # all seeds of one ladder value share one step: use the median dt of the ladder value
        med = g.groupby("ladder_value")["dt"].transform("median")
        vals = vals.assign(step=med.values)
        borrowed = links.get((name, series))
        if borrowed and (name, borrowed, obs_name) in refs:
            ref, ref_vals = refs[(name, borrowed, obs_name)]
            table, reference = error_table(vals, g["wall_time_s"].values, tolerance,
                                           residual=obs.residual, reference=ref,
                                           reference_values=ref_vals)
            reference["borrowed_from"] = borrowed
        else:
            table, reference = error_table(vals, g["wall_time_s"].values, tolerance,
                                           methods.get(name, "auto"), residual=obs.residual)
            reference["borrowed_from"] = ""
            refs[key] = ({k: v for k, v in reference.items() if k != "noise"}, vals)
        lad = g.groupby("ladder_value").agg(step=("dt", "median"), dt_limit=("dt_limit", "median"),
                                            steps=("steps", "median")).reset_index()
        table = table.merge(lad, on="step", how="left")
        table.insert(0, "observable", obs_name)
        table.insert(0, "series", series)
        table.insert(0, "name", name)
        table["scene"] = scene
        table["ladder"] = g["ladder"].iloc[0]
        table["units"] = obs.units
        table["reference"] = reference["value"]
        table["reference_se"] = reference["se"]
        table["reference_method"] = reference["method"]
        table["reference_order"] = reference["order"]
        table["reference_series"] = reference["borrowed_from"] or series
        table["noise"] = reference["noise"]
        table["headline"] = obs_name in decide.get(name, [o.name for o in OBSERVABLES[scene]
                                                          if o.headline])
        points.append(table)
    points = pd.concat(points, ignore_index=True)
    choices = []
    for (name, series, obs_name), t in points.groupby(keys, sort=False):
        k = cheapest_within(t["step"], t["steps"], t["within"] & _margin(t, limit_fraction))
        choices.append(_choice(name, series, obs_name, t, k, "observable"))
    for (name, series), t in points[points["headline"]].groupby(["name", "series"], sort=False):
        # the default step must be within for every deciding observable
        both = t.groupby("step").agg(within=("within", "all"), wall_time=("wall_time", "max"),
                                     steps=("steps", "max"), ladder_value=("ladder_value", "first"),
                                     dt_limit=("dt_limit", "max"))
        both = both.reset_index()
        ok = both["within"] & _margin(both, limit_fraction)
        k = cheapest_within(both["step"], both["steps"], ok)
        choices.append(_choice(name, series, "+".join(sorted(t["observable"].unique())), both, k,
                               "default"))
    return points, pd.DataFrame(choices)


def _margin(table, fraction):
    """True where the step is at most ``fraction`` of its stability limit (or no limit known)."""
    limit = table["dt_limit"].to_numpy(float)
    return pd.Series(~(table["step"].to_numpy(float) > fraction * limit), index=table.index)


def _choice(name, series, obs, table, k, kind):
    """One row of the choice table. kind: observable (the cheapest step for that observable) or
    default (within for every deciding observable: the series' default step)."""
    if k is None:
        return dict(name=name, series=series, observable=obs, kind=kind, ladder_value=math.nan,
                    step=math.nan, wall_time=math.nan, relative_error=math.nan, found=False)
    r = table.iloc[k]
    return dict(name=name, series=series, observable=obs, kind=kind,
                ladder_value=float(r["ladder_value"]), step=float(r["step"]),
                wall_time=float(r["wall_time"]),
                relative_error=float(r.get("relative_error", math.nan)), found=True)


# ---- the study: series tables -> dataset and summary ---------------------------------------------

def study(cases, tolerance=0.01, links=None, methods=None, decide=None, limit_fraction=1.0,
          config_json=""):
    """The accuracy dataset (:func:`to_dataset`, with the definitions and settings as attributes)
    and its markdown summary, from the long case table of every series (:func:`collect`)."""
    points, choices = analyse(cases, tolerance, links, methods, decide, limit_fraction)
    attrs = {
        "title": "millsim accuracy study: error against run time per scene",
        "tolerance": tolerance,
        "limit_fraction": limit_fraction,
        "definitions": __doc__[__doc__.index("- **reference**"):].strip(),
        "millsim_version": millsim.__version__,
        "analysis_code_version": millsim.__version__,
        "engine_hashes": ",".join(sorted(cases["engine_hash"].astype(str).unique())),
        "config_json": config_json or "",
    }
    return to_dataset(cases, points, choices, attrs), summary_markdown(points, choices)
