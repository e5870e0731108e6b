"""Error against run time (work-precision) figures from ``results/aggregate/accuracy.nc``.

One figure per accuracy name (``millsim plot error_vs_runtime_<name>``), one row per observable:
left, |relative error| of the mean over seeds against the wall time of one case, one line per
series (integrator, viscosity, mode), with the standard error of the error as bars, the noise
(sd over seeds of one case at the reference step, dotted) and the tolerance (dashed); the ringed
point is the series' default (the cheapest step within for every deciding observable), the
squared one the cheapest step for that observable alone. Right, the observable against the
time step (mean +- sd over seeds) with the converged reference. Matplotlib without pyplot state.
"""

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from ..analysis.accuracy import points_frame
from .style import label

FLOOR = 1e-4  # errors below (0.01 %, e.g. exactly zero at the reference step) are drawn here


def _tidy_log_axis(ax):
    """No labels on the minor ticks of a log x axis spanning more than a decade (they overlap);
    below a decade they are the only labels and stay."""
    lo, hi = ax.get_xlim()
    if lo > 0 and hi / lo > 10:
        ax.xaxis.set_minor_formatter(NullFormatter())


def _short(value):
    return f"{value:.3g}"


def error_vs_runtime(ds, out, name):
    """Error against wall time, and value against step, of every observable of ``name``."""
    points = points_frame(ds, "point")
    choices = points_frame(ds, "choice")
    points = points[points["name"] == name]
    if points.empty:
        have = sorted(set(points_frame(ds)["name"]))
        raise ValueError(f"name: no accuracy points for {name!r}; have {have}")
    tolerance = float(ds.attrs.get("tolerance", 0.01))
    observables = list(dict.fromkeys(points["observable"]))
    series = list(dict.fromkeys(points["series"]))
    colour = {s: f"C{k}" for k, s in enumerate(series)}
    fig = Figure(figsize=(11, 3.6 * len(observables)), layout="constrained")
    axes = np.atleast_2d(fig.subplots(len(observables), 2))
    for (left, right), obs in zip(axes, observables):
        t_obs = points[points["observable"] == obs]
        units = t_obs["units"].iloc[0]
        for s in series:
            t = t_obs[t_obs["series"] == s].sort_values("step")
            if t.empty:
                continue
            c = colour[s]
            err = np.abs(t["relative_error"].to_numpy(float))
            se = t["relative_error_se"].to_numpy(float)
            wall = t["wall_time"].to_numpy(float)
            nonzero = err > FLOOR
            shown = np.where(nonzero, err, FLOOR)
            left.errorbar(wall, shown, yerr=np.where(nonzero, np.minimum(se, 0.95 * shown), 0),
                          fmt="-o", color=c, capsize=2, ms=5,
                          label=f"{s} ({t['ladder'].iloc[0]})")
            for w, e, lv in zip(wall, shown, t["ladder_value"]):
                left.annotate(_short(lv), (w, e), textcoords="offset points", xytext=(4, 4),
                              fontsize="x-small", color=c)
            if np.any(~nonzero):
                left.plot(wall[~nonzero], shown[~nonzero], "o", mfc="white", color=c, ms=7)
            ref = t["reference"].iloc[0]
            residual = t["reference_method"].iloc[0] == "exact"
            noise = t["noise"].iloc[0]
            rel_noise = noise if residual else noise / abs(ref) if ref else np.nan
            if np.isfinite(rel_noise) and rel_noise > 0:
                left.axhline(rel_noise, color=c, ls=":", lw=1)
            for kind, style in (("observable", dict(marker="s", ms=11)),
                                ("default", dict(marker="o", ms=17))):
                pick = choices[(choices["name"] == name) & (choices["series"] == s)
                               & (choices["kind"] == kind)]
                if kind == "observable":
                    pick = pick[pick["observable"] == obs]
                if len(pick) and np.isfinite(pick["step"].iloc[0]):
                    k = int(np.argmin(np.abs(t["step"].to_numpy(float) - pick["step"].iloc[0])))
                    left.plot(wall[k], shown[k], ls="none", mfc="none", mec=c, mew=1.3, **style)
            # right: value against the step
            right.errorbar(t["step"], t["mean"], yerr=t["sd"].fillna(0), fmt="-o", color=c,
                           capsize=2, ms=4, label=s)
            if not residual:
                right.axhline(ref, color=c, ls="--", lw=0.8)
            lim = t["dt_limit"].to_numpy(float)
            if np.isfinite(lim).any():
                right.axvline(np.nanmax(lim), color=c, ls=":", lw=0.8)
        left.axhline(tolerance, color="k", ls="--", lw=1, label=f"tolerance {100 * tolerance:g} %")
        left.set(xscale="log", yscale="log", ylim=(FLOOR / 2, None),
                 xlabel="wall time of one case [s] (fastest seed)",
                 ylabel="|error| / |reference|" if t_obs["reference_method"].iloc[0] != "exact"
                 else "|residual| (exact value 0)",
                 title=f"{obs}: error vs run time (dotted: noise; open: |error| < 0.01 %)")
        left.title.set_fontsize("small")
        _tidy_log_axis(left)
        left.legend(fontsize="x-small")
        method = t_obs["reference_method"].iloc[0]
        right.set(xscale="log", xlabel=label("time step", "s") + " (dotted: stability limit)",
                  ylabel=label(obs, units),
                  title=f"mean +- sd over seeds; dashed: reference ({method})")
        right.title.set_fontsize("small")
        _tidy_log_axis(right)
        right.legend(fontsize="x-small")
    fig.suptitle(f"Error against run time: {name} (labels: ladder values)")
    fig.savefig(out)
