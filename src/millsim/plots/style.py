"""One look for every millsim figure: rcParams, symbols and units in mathtext, and the rule for
lines through few points.

``millsim.plots.plot`` draws every registered figure inside ``matplotlib.rc_context(RC)``, so the
drawing functions set no fonts, sizes or dpi of their own. Conventions they follow:

- simulation: filled markers with 95 % intervals; reference data: open squares, dashed; models
  (equations, fits): lines without markers, evaluated on a dense grid (``dense``);
- symbols through ``SYMBOL`` (mu, eta, omega, n/n_c as mathtext), units through ``unit``
  (``"m s-1"`` -> m s$^{-1}$), axis labels through ``label``;
- maps and images draw no grid (``ax.grid(False)``);
- a line joins simulated points only where there are at least ``MIN_TREND`` of them
  (``points``); fewer are drawn as markers and the figure says how many, so that two points never
  read as a trend.
"""

import re

import numpy as np

MIN_TREND = 3

RC = {
    "font.family": "DejaVu Sans",
    "font.size": 9,
    "axes.titlesize": 9.5,
    "axes.labelsize": 9,
    "legend.fontsize": 7.5,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "figure.titlesize": 10.5,
    "legend.frameon": False,
    "lines.linewidth": 1.4,
    "lines.markersize": 5,
    "errorbar.capsize": 2.5,
    "axes.grid": True,
    "grid.alpha": 0.25,
    "grid.linewidth": 0.6,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "image.cmap": "viridis",
    # 3e5 as 3 x 10^5 on the axis offset, not 300000
    "axes.formatter.limits": (-3, 4),
    "axes.formatter.use_mathtext": True,
    "figure.dpi": 100,
    "savefig.dpi": 150,
    "mathtext.default": "regular",
}

# symbols as they appear in labels, legends and titles
SYMBOL = {
    "mu": r"$\mu$",
    "eta": r"$\eta$",
    "eta_sim": r"$\eta_\mathrm{sim}$",
    "eta_exp": r"$\eta_\mathrm{exp}$",
    "omega": r"$\omega$",
    "gamma": r"$\gamma$",
    "n_over_nc": r"$n/n_\mathrm{c}$",
    "t10": r"$t_{10}$",
    "Ek/m": r"$E_\mathrm{k}/m$",
    "E50b": r"$E_\mathrm{50b}$",
}

_POWER = re.compile(r"^([A-Za-z\u00b5%]+)(-?\d+)$")


def unit(units):
    """A units string of the case files (UDUNITS: ``"J kg-1"``, ``"s-1 m-2"``, ``"W2"``) in
    mathtext: J kg$^{-1}$. ``"1"`` (dimensionless) gives ``""``."""
    units = str(units).strip()
    if units in ("", "1"):
        return ""
    out = []
    for term in units.split():
        m = _POWER.match(term)
        out.append(f"{m.group(1)}$^{{{m.group(2)}}}$" if m else term)
    return " ".join(out).replace("$ $", r"$\,$")


def label(name, units="1"):
    """Axis label ``name [units]``; no brackets for a dimensionless quantity."""
    u = unit(units)
    return f"{name} [{u}]" if u else name


def dense(lo, hi, n=400, log=False):
    """The grid a model curve is drawn on."""
    return np.geomspace(lo, hi, n) if log else np.linspace(lo, hi, n)


def points(ax, x, y, yerr=None, dodge=0.0, **kw):
    """Simulated points with their intervals, joined by a line only if there are at least
    MIN_TREND finite ones; ``dodge`` shifts them sideways (data units) where several series share
    the same few x. Returns the number of finite points."""
    x, y = np.asarray(x, float) + dodge, np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    keep = np.flatnonzero(ok)[np.argsort(x[ok])]
    if yerr is not None and np.ndim(yerr):
        yerr = np.asarray(yerr, float)[..., keep]
    line = kw.pop("ls", "-")
    line = line if len(keep) >= MIN_TREND else "none"
    ax.errorbar(x[keep], y[keep], yerr=yerr, ls=line, **{"marker": "o", **kw})
    return int(ok.sum())


def dodge_step(x, series):
    """Sideways shift between ``series`` series sharing the values ``x``: a fortieth of their
    span (of the value itself for one x), so that the intervals do not hide each other."""
    x = np.unique(np.asarray(x, float))
    span = float(x.max() - x.min()) or abs(float(x.max())) or 1.0
    return span / 40 if series > 1 else 0.0


def few_points_note(ax, n, what, dodged=False):
    """Say on the axes that ``n`` (< MIN_TREND) points are shown without a line."""
    if n >= MIN_TREND:
        return
    text = f"{n} {what}{'s' if n != 1 else ''}: no trend line"
    if dodged:
        text += "; symbols shifted sideways"
    ax.text(0.99, 0.01, text, transform=ax.transAxes, ha="right", va="bottom", fontsize=7.5,
            color="0.35", style="italic")
