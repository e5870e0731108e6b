"""Tavares single-particle verification figures (seed 002 section 4.1, Figs 8, 11, 13-16, Table 2)
from the aggregate of ``millsim analyse tavares aggregate`` (tavares_verification.nc); the model
lines are the analytic predictions of millsim.models.breakage.tavares_predictions. Matplotlib
without pyplot state.
"""

import math

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from ..models.breakage import tavares
from ..models.breakage.tavares_predictions import breakage_probability


def _figure(figsize):
    return Figure(figsize=figsize, layout="constrained")


def probability(ds, out):
    """Seed 002 Fig. 8: breakage probability vs input specific energy, 3 materials, single impact
    and drop weight; analytic eq 1 curves and 95 % intervals."""
    fig = _figure((7.5, 5))
    ax = fig.subplots()
    colours = matplotlib.colormaps["tab10"]
    markers = {"single": "o", "drop_weight": "s"}
    for j, mat_name in enumerate(ds["prob_material"].values):
        path = ds.attrs.get("prob_materials_file", tavares.MATERIALS_FILE)
        mat = _material(str(mat_name), path)
        share = float(np.nanmean(ds["prob_absorbed_share"].isel(prob_material=j)))
        d = float(ds.attrs.get("prob_diameter_m", 5.5e-3))
        E = ds["prob_specific_energy"].isel(prob_material=j)
        emax = float(np.nanmax(E)) * 1.2
        x = np.geomspace(emax / 100, emax, 300)
        ax.plot(x, breakage_probability(mat, d, x, share), "-", color=colours(j), lw=1.2,
                label=f"{mat_name}: model (eq 1)")
        for m, mode in enumerate(ds["prob_mode"].values):
            sub = {k: ds[f"prob_{k}"].isel(prob_mode=m, prob_material=j).values
                   for k in ("specific_energy", "fraction", "ci_lo", "ci_hi")}
            ok = np.isfinite(sub["fraction"])
            if not ok.any():
                continue
            ax.errorbar(sub["specific_energy"][ok], sub["fraction"][ok],
                        yerr=[sub["fraction"][ok] - sub["ci_lo"][ok], sub["ci_hi"][ok] - sub["fraction"][ok]],
                        fmt=markers.get(str(mode), "^"), color=colours(j),
                        mfc="none" if mode == "drop_weight" else None,
                        capsize=2, ls="none", label=f"{mat_name}: {mode} (sim., 95% CI)")
    ax.set(xscale="log", xlabel="input specific energy Ek/m [J/kg]", ylabel="fraction broken [1]",
           ylim=(-0.02, 1.02), title="Breakage probability: simulation vs model (seed 002 Fig. 8)")
    ax.legend(fontsize="x-small")
    fig.savefig(out, dpi=120)


def repeated(ds, out):
    """Seed 002 Fig. 11: cumulative fraction broken after each repeated impact, several gamma."""
    fig = _figure((7, 5))
    ax = fig.subplots()
    colours = matplotlib.colormaps["viridis"]
    ng = ds.sizes["gamma"]
    for g in range(ng):
        c = colours(g / max(ng - 1, 1))
        sub = ds.isel(gamma=g)
        k = ds["impact"].values
        ax.plot(k, sub["rep_analytic"], "-", color=c, label=f"model, gamma = {float(ds['gamma'][g]):g}")
        f = sub["rep_fraction"].values
        ax.errorbar(k, f, yerr=[f - sub["rep_ci_lo"].values, sub["rep_ci_hi"].values - f], fmt="o",
                    color=c, ms=3, capsize=2, ls="none")
    ax.set(xlabel="impact number", ylabel="cumulative fraction broken [1]", ylim=(0, 1),
           title=f"Repeated impacts: {ds.attrs.get('rep_material', '')} "
                 f"{1e3 * float(ds.attrs.get('rep_diameter_m', math.nan)):g} mm at "
                 f"{float(ds.attrs.get('rep_specific_energy_J_per_kg', math.nan)):g} J/kg "
                 "(seed 002 Fig. 11; symbols: simulation, 95% CI)")
    ax.title.set_fontsize("small")
    ax.legend(fontsize="small")
    fig.savefig(out, dpi=120)


def t10(ds, out):
    """Seed 002 Fig. 16: t10 of the product vs input specific energy, simulation vs eq 7.
    Colour: material/mode/size; marker: when particles break (breakage_at)."""
    fig = _figure((8.5, 5.5))
    ax = fig.subplots()
    colours = matplotlib.colormaps["tab10"]
    markers = {"first_reach": "o", "end_of_loading": "s"}
    groups = []
    for i, name in enumerate(ds["frag_case"].values):
        group, _, at = str(name).rpartition("/")
        first = group not in groups
        if first:
            groups.append(group)
        c = colours(groups.index(group))
        sub = ds.isel(frag_case=i)
        E = sub["t10_specific_energy"].values
        ok = np.isfinite(sub["t10"].values)
        order = np.argsort(E[ok])
        if first:  # the model does not depend on breakage_at
            for key, style, lw in (("t10_model", "-", 1.4), ("t10_model_all", ":", 1.0),
                                   ("t10_primary", "--", 0.8)):
                ax.plot(E[ok][order], sub[key].values[ok][order], style, color=c, lw=lw,
                        label=f"{group}: eq 7" if key == "t10_model" else None)
        t = sub["t10"].values
        ax.errorbar(E[ok], t[ok], yerr=[t[ok] - sub["t10_lo"].values[ok], sub["t10_hi"].values[ok] - t[ok]],
                    fmt=markers.get(at, "^"), color=c, mfc="white" if at == "end_of_loading" else c,
                    capsize=2, ls="none", label=f"{group}, {at}")
    ax.set(xscale="log", xlabel="input specific energy Ek/m [J/kg]", ylabel="t10 [%]",
           title="t10 vs energy (seed 002 Fig. 16), 95% bootstrap intervals\n"
                 "solid: eq 7 (E50b of the broken), dotted: E50 of all, dashed: eq 9")
    ax.title.set_fontsize("small")
    ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.savefig(out, dpi=120)


def size_distributions(ds, out):
    """Seed 002 Figs. 13-15: cumulative product size distribution of the broken particles, with the
    fines extension (eq 11) below the smallest family size; lines: eq 10 model."""
    n = ds.sizes["frag_case"]
    fig = _figure((6 * n, 4.8))
    axes = np.atleast_1d(fig.subplots(1, n, squeeze=False)[0])
    colours = matplotlib.colormaps["plasma"]
    x = ds["sieve"].values
    nr = ds.sizes["frag_ratio"]
    for i, ax in enumerate(axes):
        sub = ds.isel(frag_case=i)
        for r in range(nr):
            c = colours(r / max(nr, 1))
            sim = sub["psd_sim"].isel(frag_ratio=r).values
            if not np.isfinite(sim).any():
                continue
            E = float(sub["t10_specific_energy"].isel(frag_ratio=r))
            ax.plot(x, sub["psd_model"].isel(frag_ratio=r), "-", color=c, lw=1)
            ax.plot(x, sim, "o", color=c, ms=3, label=f"{E:.0f} J/kg")
        ax.axvline(tavares.SIEVE_RATIO ** -tavares.STANDARD_CLASSES, color="k", ls="--", lw=0.8)
        ax.axvline(0.05, color="r", ls="--", lw=0.8)
        ax.set(xscale="log", yscale="log", xlabel="size / initial size [1]", ylabel="cumulative % passing",
               ylim=(0.01, 110), title=f"{sub['frag_case'].item()} (symbols: sim., lines: model)")
        ax.title.set_fontsize("small")
        ax.legend(fontsize="x-small")
    fig.savefig(out, dpi=120)


def table2(ds, out):
    """Seed 002 Table 2: mean % passing of the t10' = 3 % families, ours vs the paper's."""
    fig = _figure((6.5, 4.5))
    ax = fig.subplots()
    x = ds["table2_sieve"].values
    ax.plot(x, ds["table2_target"], "k-", lw=1, label="eq 10 target (Table 1 average parameters)")
    ax.plot(x, ds["table2_seed"], "s", mfc="none", label="seed 002 Table 2 (7 families)")
    ax.plot(x, ds["table2_families"], "o", ms=4, label="millsim families")
    ax.set(xscale="log", yscale="log", xlabel="relative size x/d [1]", ylabel="cumulative % passing",
           title="Progeny families at t10' = 3 %")
    ax.legend(fontsize="small")
    fig.savefig(out, dpi=120)


def _material(name, path, truncation="single_particle"):
    return tavares.load_materials(path, truncation=truncation)[name]
