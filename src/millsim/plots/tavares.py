"""Tavares single-particle verification figures (Tavares et al. 2021, section 4.1, Figs 8, 11,
13-16, Table 2) from the aggregate of ``millsim analyse tavares aggregate``
(tavares_verification.nc); the model lines are the analytic predictions
of millsim.models.breakage.tavares_predictions. Matplotlib without pyplot state.
"""

import math

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from ..models.breakage import tavares, tavares_materials
from ..models.breakage.tavares_predictions import (
    breakage_probability,
    product_passing_model,
    t10_expected,
    t10_model,
)
from .style import SYMBOL, dense, few_points_note, label

ENERGY = label(f"input specific energy {SYMBOL['Ek/m']}", "J kg-1")
T10 = label(SYMBOL["t10"], "%")


def _figure(figsize):
    return Figure(figsize=figsize, layout="constrained")


def probability(ds, out):
    """Fig. 8 of Tavares et al. 2021: breakage probability vs input specific energy, 3 materials,
    single impact and drop weight; analytic eq 1 curves and 95 % intervals."""
    fig = _figure((7.0, 4.6))
    ax = fig.subplots()
    colours = matplotlib.colormaps["tab10"]
    markers = {"single": "o", "drop_weight": "s"}
    for j, mat_name in enumerate(ds["prob_material"].values):
        path = ds.attrs.get("prob_materials_file", tavares_materials.MATERIALS_FILE)
        mat = _material(str(mat_name), path)
        share = float(np.nanmean(ds["prob_absorbed_share"].isel(prob_material=j)))
        d = float(ds.attrs.get("prob_diameter_m", 5.5e-3))
        E = ds["prob_specific_energy"].isel(prob_material=j)
        emax = float(np.nanmax(E)) * 1.2
        x = dense(emax / 100, emax, log=True)
        ax.plot(x, breakage_probability(mat, d, x, share), "-", color=colours(j),
                label=f"{mat_name}: model (eq 1)")
        for m, mode in enumerate(ds["prob_mode"].values):
            sub = {k: ds[f"prob_{k}"].isel(prob_mode=m, prob_material=j).values
                   for k in ("specific_energy", "fraction", "ci_lo", "ci_hi")}
            ok = np.isfinite(sub["fraction"])
            if not ok.any():
                continue
            f = sub["fraction"][ok]
            ax.errorbar(sub["specific_energy"][ok], f,
                        yerr=[f - sub["ci_lo"][ok], sub["ci_hi"][ok] - f],
                        fmt=markers.get(str(mode), "^"), color=colours(j),
                        mfc="white" if mode == "drop_weight" else None, ls="none",
                        label=f"{mat_name}: {mode} (simulation, 95 % interval)")
    ax.set(xscale="log", xlabel=ENERGY, ylabel="fraction broken", ylim=(-0.02, 1.02),
           title="Breakage probability: simulation vs model (Fig. 8 of Tavares et al. 2021)")
    ax.legend(loc="upper left")
    fig.savefig(out)


def repeated(ds, out):
    """Fig. 11 of Tavares et al. 2021: cumulative fraction broken after each repeated impact,
    several gamma."""
    fig = _figure((6.5, 4.4))
    ax = fig.subplots()
    colours = matplotlib.colormaps["viridis"]
    ng = ds.sizes["gamma"]
    for g in range(ng):
        c = colours(g / max(ng - 1, 1))
        sub = ds.isel(gamma=g)
        k = ds["impact"].values
        gamma = float(ds["gamma"][g])
        ax.plot(k, sub["rep_analytic"], "-", color=c,
                label=f"model (eqs 1-6), {SYMBOL['gamma']} = {gamma:g}")
        f = sub["rep_fraction"].values
        ax.errorbar(k, f, yerr=[f - sub["rep_ci_lo"].values, sub["rep_ci_hi"].values - f], fmt="o",
                    color=c, ms=4, ls="none",
                    label=f"simulation, 95 % interval, {SYMBOL['gamma']} = {gamma:g}")
    ax.set(xlabel="impact number", ylabel="cumulative fraction broken", ylim=(0, 1),
           title=f"Repeated impacts: {ds.attrs.get('rep_material', '')}, "
                 f"{1e3 * float(ds.attrs.get('rep_diameter_m', math.nan)):g} mm at "
                 f"{float(ds.attrs.get('rep_specific_energy_J_per_kg', math.nan)):g} J kg$^{{-1}}$ "
                 "(Fig. 11 of Tavares et al. 2021)")
    ax.xaxis.get_major_locator().set_params(integer=True)
    ax.legend(loc="lower right")
    fig.savefig(out)


def _frag_model(ds, i):
    """(material, diameter, absorbed share) of fragmentation case ``i``: the model curves' input."""
    path = ds.attrs.get("frag_materials_file", tavares_materials.MATERIALS_FILE)
    mat = _material(str(ds["frag_material"].values[i]), path)
    share = float(np.nanmean(ds["t10_absorbed_share"].isel(frag_case=i)))
    return mat, float(ds["frag_diameter"].values[i]), share


def t10(ds, out):
    """Fig. 16 of Tavares et al. 2021: t10 of the product vs input specific energy, simulation vs
    eq 7 on a dense grid, one panel per material/mode/size; marker: when particles break
    (breakage_at: filled at the first reach, open at the end of loading)."""
    markers = {"first_reach": "o", "end_of_loading": "s"}
    groups = list(dict.fromkeys(str(name).rpartition("/")[0] for name in ds["frag_case"].values))
    cols = min(len(groups), 2)
    rows = -(-len(groups) // cols)
    fig = _figure((5.4 * cols + 0.6, 3.9 * rows + 0.6))
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False).ravel())
    energies = ds["t10_specific_energy"].values
    n = 0
    for ax, group in zip(axes, groups):
        cases = [i for i, name in enumerate(ds["frag_case"].values)
                 if str(name).rpartition("/")[0] == group]
        mat, d, share = _frag_model(ds, cases[0])  # the model does not depend on breakage_at
        mine = energies[cases]
        E = dense(np.nanmin(mine) / 1.6, np.nanmax(mine) * 1.6, 200, log=True)
        ax.plot(E, [t10_expected(mat, d, e, share, grid=20_000) for e in E], "-", color="k",
                lw=1.3, label="mean of eq 8 over the broken (tested)")
        for median, style, text in (("broken", "-.", f"eq 7, {SYMBOL['E50b']} of the broken"),
                                    ("all", ":", "eq 7, median of all")):
            ax.plot(E, [t10_model(mat, d, e, share, median) for e in E], style, color="k",
                    lw=0.9, label=text)
        ax.axhline(float(np.nanmean(ds["t10_primary"].isel(frag_case=cases[0]))), color="0.5",
                   ls="--", lw=0.9, label="eq 9 (breakage at the fracture energy)")
        for i in cases:
            at = str(ds["frag_case"].values[i]).rpartition("/")[2]
            sub = ds.isel(frag_case=i)
            t = sub["t10"].values
            ok = np.isfinite(t)
            n = max(n, int(ok.sum()))
            ax.errorbar(sub["t10_specific_energy"].values[ok], t[ok],
                        yerr=[t[ok] - sub["t10_lo"].values[ok],
                              sub["t10_hi"].values[ok] - t[ok]],
                        fmt=markers.get(at, "^"), color="C0" if at == "first_reach" else "C3",
                        mfc="white" if at == "end_of_loading" else None, ls="none",
                        label=f"simulation, {at.replace('_', ' ')} (95 % interval)")
        few_points_note(ax, n, "energy")
        ax.set(xscale="log", xlabel=ENERGY, ylabel=T10, ylim=(0, None),
               title=group.replace("_", " "))
        ax.legend(loc="upper left", fontsize=7)
    for ax in axes[len(groups):]:
        ax.set_visible(False)
    fig.suptitle(f"{SYMBOL['t10']} of the broken particles' product vs energy "
                 "(Fig. 16 of Tavares et al. 2021)")
    fig.savefig(out)


def size_distributions(ds, out):
    """Figs. 13-15 of Tavares et al. 2021: cumulative product size distribution of the broken
    particles, with the fines extension (eq 11) below the smallest family size; lines: eq 10 model
    on a dense grid."""
    n = ds.sizes["frag_case"]
    cols = min(n, 2)
    rows = -(-n // cols)
    fig = _figure((5.6 * cols + 1.2, 4.2 * rows))
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False).ravel())
    energies = ds["t10_specific_energy"].values
    norm = matplotlib.colors.LogNorm(np.nanmin(energies), np.nanmax(energies) * 1.0001)
    cmap = matplotlib.colormaps["plasma"]
    x = ds["sieve"].values
    xd = dense(x.min(), x.max(), log=True)
    for i, ax in enumerate(axes[:n]):
        sub = ds.isel(frag_case=i)
        mat, d, share = _frag_model(ds, i)
        for r in range(ds.sizes["frag_ratio"]):
            sim = sub["psd_sim"].isel(frag_ratio=r).values
            if not np.isfinite(sim).any():
                continue
            E = float(sub["t10_specific_energy"].isel(frag_ratio=r))
            c = cmap(0.85 * norm(E))
            ax.plot(xd, product_passing_model(mat, d, E, share, xd), "-", color=c, lw=1,
                    label=f"{E:.0f} J kg$^{{-1}}$: model (line), simulation (symbols)")
            ax.plot(x, sim, "o", color=c, ms=3)
        ax.axvline(tavares.SIEVE_RATIO ** -tavares.STANDARD_CLASSES, color="k", ls="--", lw=0.8,
                   label="smallest family size 0.21 d")
        ax.axvline(0.05, color="r", ls="--", lw=0.8, label="global minimum size d/20")
        ax.set(xscale="log", yscale="log", xlabel="size / initial size",
               ylabel="cumulative passing [%]", ylim=(0.01, 110),
               title=f"{sub['frag_case'].item()}\n(symbols: simulation; lines: eq 10 at the eq 7 "
                     f"{SYMBOL['t10']})")
        ax.legend(loc="lower right")  # cumulative curves leave it empty
    for ax in axes[n:]:
        ax.set_visible(False)
    fig.savefig(out)


def table2(ds, out):
    """Table 2 of Tavares et al. 2021: mean % passing of the t10' = 3 % families, ours vs
    the paper's."""
    fig = _figure((6.0, 4.2))
    ax = fig.subplots()
    x = ds["table2_sieve"].values
    xd = dense(x.min(), x.max(), log=True)
    ax.plot(xd, tavares.cumulative_passing(3.0, xd, tavares.TABLE1_AVERAGE), "k-", lw=1,
            label="eq 10 target (Table 1 average parameters)")
    ax.plot(x, ds["table2_paper"], "s", mfc="none",
            label="Tavares et al. 2021, Table 2 (7 families)")
    ax.plot(x, ds["table2_families"], "o", ms=4, label="millsim families")
    ax.set(xscale="log", yscale="log", xlabel="relative size x/d", ylabel="cumulative passing [%]",
           title=f"Progeny families at {SYMBOL['t10']}' = 3 %")
    ax.legend()
    fig.savefig(out)


def _material(name, path, truncation="single_particle"):
    return tavares_materials.load_materials(path, truncation=truncation)[name]
