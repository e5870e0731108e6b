"""Every figure millsim draws, in one registry: name -> drawing function, input, caption.

``millsim plot --list`` prints the registry (name, input, caption; tab-separated), ``millsim plot
NAME INPUT --out FILE`` draws one figure. The pipeline takes its figure names and report captions
from that listing, and writes figure NAME to ``results/plots/NAME.png``.

An entry's ``input`` says what the figure is drawn from:

- ``aggregate:<dataset>``: a netCDF aggregate (``results/aggregate/<dataset>.nc`` in the pipeline),
  read with millsim.io.read_case;
- ``table:<dataset>``: a CSV table (``results/calibration/<dataset>.csv``), read with pandas;
- ``snapshots``: particle snapshots (.h5 of ``millsim run --snapshots``), passed as a path.

A name may hold one ``{name}`` field (``error_vs_runtime_{name}``): a family of figures, one per
value, which the drawing function receives as the keyword ``name``. The drawing functions live in
one module per study (ballmill, ballmill3d, animation, bed_impact, tavares, stirred_mill, accuracy), imported
only when a figure is drawn.
"""

import importlib
import os
import re
from dataclasses import dataclass

__all__ = ["Plot", "PLOTS", "find", "plot", "listing"]

INPUT_KINDS = ("aggregate", "table", "snapshots")


@dataclass(frozen=True)
class Plot:
    name: str
    draw: str  # "module:function" of this package; called as function(data, out, **fields)
    input: str  # aggregate:<dataset> | table:<dataset> | snapshots
    caption: str

    def function(self):
        module, function = self.draw.split(":")
        return getattr(importlib.import_module(f".{module}", __name__), function)

    def match(self, kind):
        """The fields of figure ``kind`` if it is this entry (or one of its family), else None."""
        if "{" not in self.name:
            return {} if kind == self.name else None
        pattern = re.escape(self.name).replace(r"\{name\}", r"(?P<name>[A-Za-z0-9_]+)")
        hit = re.fullmatch(pattern, kind)
        return hit.groupdict() if hit else None


_SYNTHETIC = ("The shipped reference (config/reference/stirred_mill_power.csv) is a SYNTHETIC twin "
              "produced by this engine, not a measurement; config/reference/SOURCES.md says how "
              "to drop in measured data.")
_STIRRED = ("The title names the simulated domain: the quick study runs a periodic slice around "
            "one disk of a geometrically scaled chamber (docs/stirred_mill.md), whose powers are "
            "those of the slice, not of the LS1; config/paper.yaml and config/ls1_power.yaml run "
            "the full chamber.")
_FEW = ("Fewer than 3 simulated points are drawn without a connecting line, and the figure says "
        "how many.")

_ENTRIES = (
    # ---- ball mill 2D (Buchholtz et al. 2000) ----
    Plot("ballmill_rate", "ballmill:rate", "aggregate:ballmill",
         "Comminution rate (fracture events per second in steady state) relative to its maximum, "
         "against the rotation speed as a fraction of the critical speed n_c (Fig. 6 of "
         "Buchholtz et al. 2000). Error bars: 95% confidence half-width from block averages. Black "
         "line: the Bond/Austin speed factor phi(1 - 0.1/2^(9 - 10 phi)), normalised; an empirical "
         "shape for mill power, not for comminution rate, so only the shape is comparable. Lower "
         "panel: mean drive power of the same cases."),
    Plot("ballmill_size_distributions", "ballmill:size_distributions", "aggregate:ballmill",
         "Fragment size distribution (Fig. 5 of Buchholtz et al. 2000) as the field reads one: "
         "cumulative % passing (per cent of the grain mass with radius below r) against the "
         "radius r at the upper edge of each radius class, on log axes, one line per rotation "
         "speed, from the mass fraction per class averaged over the recorded snapshots. The "
         "spread over the snapshots is kept per class in the aggregate (mass_fraction_std), "
         "not drawn."),
    Plot("ballmill_fragmentation_maps", "ballmill:fragmentation_maps", "aggregate:ballmill",
         "Where grains break (Fig. 7 of Buchholtz et al. 2000): fracture events per second and "
         "unit area on a grid over the drum cross-section (mm), one panel per rotation speed, one "
         "grey scale for all panels."),
    Plot("ballmill_pressure_maps", "ballmill:pressure_maps", "aggregate:ballmill_forcechain",
         "Time-averaged local pressure (Fig. 12 of Buchholtz et al. 2000) in the force-chain "
         "study, run without fragmentation: one panel per rotation speed, one grey scale for all "
         "panels, ending at the 99th percentile of the non-zero cells (the few cells above it are "
         "black; the colour bar gives the cap)."),
    Plot("ballmill_force_chains", "ballmill:force_chains", "aggregate:ballmill_forcechain",
         "Force-chain statistics (Figs. 10-11 of Buchholtz et al. 2000), run without "
         "fragmentation, one colour per rotation speed. Left: number of chains of each length "
         "(grains in the chain; the last class holds all longer ones), counted over all records, "
         "as symbols with their exact 95% Poisson (Garwood) intervals, which treat the chains as "
         "independent; counts are small integers in a short run, so no line joins the lengths "
         "and the axis is linear (logarithmic once an interval reaches above 50). Middle: "
         "mean over the chains of each length of their largest grain pressure (no interval: "
         "the aggregate keeps the mean only). Right: mean force against the relative position "
         "along a chain, over all chains. Symbols of the speeds are shifted sideways around "
         "each length."),
    Plot("animation", "animation:animation", "snapshots",
         "Animation of a case from its particle snapshots: grains coloured by speed, drum wall "
         "and lifter particles grey."),
    # ---- ball mill 3D (issue 52): speed x filling ----
    Plot("ballmill3d_power", "ballmill3d:power", "aggregate:ballmill3d",
         "Mean drive power (shell and end walls) of the 3D ball mill against the rotation speed as "
         "a fraction of the critical speed, one colour per filling J, with 95% half-widths (MSER-5 "
         "and batch means). Dashed: the net power of Morrell's C-model (Morrell 1996; dry, "
         "cylindrical section) at the cases' speeds and charge density, scaled to the simulated "
         "powers by least squares (factor in the legend): a reference SHAPE, as a small DEM mill "
         "and the industrial model differ in absolute power. Dotted: the simulated maximum, the "
         "vertex of the parabola through the highest point and its neighbours (none where the "
         "sweep does not bracket it); grey band: 0.7-0.9 of critical. " + _FEW),
    Plot("ballmill3d_charge_shape", "ballmill3d:charge_shape", "aggregate:ballmill3d",
         "Toe (squares) and shoulder (circles) angles of the charge, from the vertical below the "
         "axis and positive in the direction of rotation, against the rotation speed, one colour "
         "per filling J; dashed: Morrell's empirical relations (Morrell 1996) at the same speeds "
         "and fillings. " + _FEW),
    Plot("ballmill3d_spectra", "ballmill3d:spectra", "aggregate:ballmill3d",
         "Impact-energy spectra: impacts per second in each energy bin against the bin's energy, "
         "per contact type (solid: normal, dashed: tangential energy), one panel per rotation "
         "speed and filling, log-log; bins with no impact are left out. Where the cases hold no "
         "spectra the figure says so."),
    Plot("ballmill3d_breakage_rate", "ballmill3d:breakage_rate", "aggregate:ballmill3d",
         "Breakage rate per ore size class (the selection function: breakage events of parents in "
         "the class per second over the mean number of particles in it) against the lower edge of "
         "the class, one colour per rotation speed, one panel per filling, with 95% half-widths "
         "(lower bars cut short of zero on the log axis); classes without breakage are not "
         "drawn."),
    # ---- bed impact (Tavares et al. 2021, section 4.2) ----
    Plot("bed_broken_mass", "bed_impact:broken_mass", "aggregate:bed_breakage",
         "Broken mass (mass passing 4.75 mm, incl. dummy spheres and fines, % of the bed) after "
         "one impact of the 88 mm, 2.78 kg steel ball, against the impact energy per bed "
         "configuration and material; the dotted line marks 3.05 J, the energy of Fig. 22 "
         "of Tavares et al. 2021. Where several configurations were run at 3.05 J "
         "(config/paper.yaml), a second panel has one bar per configuration, as Fig. 22. Points: "
         "mean over seeds; whiskers: standard deviation (none with one seed); dots: single seeds. "
         "Simulation only: the paper's measurements exist only as a figure and are not reproduced "
         "here. " + _FEW),
    Plot("bed_capture_radius", "bed_impact:capture_radius", "aggregate:bed_breakage",
         "Capture radius (largest horizontal distance from the ball's axis of an original bed "
         "particle that broke; 0 when only the central particle broke) against impact energy, as "
         "Fig. 20 of Tavares et al. 2021. It is the distance of one particle, which moves a "
         "fraction of a millimetre before it breaks, so it lies at or just beyond one of the "
         "bed's site radii: dotted lines and left ticks (mm), named on the right "
         "by hexagonal ring (a ring k spans k sqrt(3)/2 to k pitches; 'layer 2': sites of the "
         "second layer). One symbol per seed and energy, its area the number of seeds with that "
         "radius (seeds within 0.05 mm drawn as one, at their mean); beds side by side around "
         "each energy; no line joins the energies, as the radius jumps from site to site."),
    Plot("bed_size_distributions", "bed_impact:size_distributions", "aggregate:bed_breakage",
         "Product size distributions (cumulative % passing; dummy spheres and unresolved fines "
         "spread below their size along the family's eq 10 curve, eq 11 below d/75), mean over "
         "seeds: one panel per bed run at several "
         "impact energies, a line per energy (Fig. 21 of Tavares et al. 2021), and one panel per "
         "material run in several bed configurations, a line per configuration at 3.05 J "
         "(Fig. 23). With one bed at one energy, that one distribution."),
    # ---- Tavares single-particle verification (Tavares et al. 2021, section 4.1) ----
    Plot("tavares_probability", "tavares:probability", "aggregate:tavares_verification",
         "Breakage probability against the input (stressing) specific energy Ek/m of 5.5 mm "
         "particles, single impact on a steel plate (filled) and drop-weight test (open; striker "
         "and anvil contacts summed), as Fig. 8 of Tavares et al. 2021. Lines: eq 1 at "
         "the absorbed energy k_s/(k_p+k_s) Ek/m on a dense grid; bars: 95% Clopper-Pearson "
         "intervals. Verdict: exact binomial p-values at the points, combined by Bonferroni, "
         "the tests decided by Holm over the study (family-wise 5 %; verdicts on the report's "
         "landing page)."),
    Plot("tavares_repeated", "tavares:repeated", "aggregate:tavares_verification",
         "Cumulative fraction broken after each of n repeated impacts at one energy, one colour "
         "per damage coefficient gamma, as Fig. 11 of Tavares et al. 2021. Lines: eqs 1-6 "
         "integrated over the fracture-energy distribution; symbols: simulation with 95% "
         "Clopper-Pearson intervals. Verdict: exact binomial p-values after each impact, "
         "combined by Bonferroni, decided by Holm over the study (family-wise 5 %)."),
    Plot("tavares_t10", "tavares:t10", "aggregate:tavares_verification",
         "t10 of the broken particles' product (fines included) against input specific energy, as "
         "Fig. 16 of Tavares et al. 2021, for each way of deciding when a particle breaks (filled: "
         "at the first reach of its fracture energy; open: at the end of loading). Solid: the "
         "mean of eq 8 over the particles that break, which the verdict tests; dash-dot: eq 7 "
         "with E50b the median fracture energy of the broken particles, dotted: with the median "
         "of all (the paper's population fit, reported), on a dense grid of energies; dashed: "
         "eq 9 (breakage at exactly the fracture energy). Bars: 95% bootstrap intervals over "
         "particles (drawn, not tested). Verdict (end of loading): each t10 against the model's "
         "Monte Carlo distribution of the mean of the broken, p-values combined by Bonferroni "
         "and Holm (family-wise 5 %). " + _FEW),
    Plot("tavares_size_distributions", "tavares:size_distributions",
         "aggregate:tavares_verification",
         "Cumulative size distribution of the broken particles' product, one panel per "
         "fragmentation case, one colour per energy: symbols, the simulation (dummy class spread "
         "below x_min along the family's eq 10 curve, eq 11 below d/75); lines, eq 10 at the eq 7 "
         "t10 on a dense grid of sizes, as "
         "Figs 13-15 of Tavares et al. 2021. Black dashed: smallest family size 0.21 d; red "
         "dashed: global minimum size d/20."),
    Plot("tavares_table2", "tavares:table2", "aggregate:tavares_verification",
         "Mean cumulative % passing of the progeny families generated for t10' = 3% (dots) "
         "against Table 2 of Tavares et al. 2021 (open squares) and the eq 10 target with "
         "the Table 1 average parameters (line, dense grid)."),
    # ---- stirred media mill (the LabStar LS1 paper) ----
    Plot("stirred_mill_power", "stirred_mill:power", "aggregate:stirred_mill",
         "Net power against agitator speed, one colour per simulation viscosity, with 95% "
         "block-mean intervals, from the aggregate of the power study. " + _FEW + " " + _STIRRED),
    Plot("stirred_mill_typology", "stirred_mill:typology", "aggregate:stirred_mill",
         "Top: share of the dissipated energy by contact typology per case (Fig. 9 "
         "of the LS1 paper), signed, one bar per typology from 0 with its value: the rolling part "
         "of the tangential dissipation can be negative (friction drives bead spin that "
         "lubrication then dissipates; docs/stirred_mill.md), so it is drawn below 0, and "
         "the shares of a case sum to 100% (written above it with the dissipated power). Torsion "
         "is 0 in this model and not drawn. Bottom: energy-balance residual (agitator work - "
         "changes of kinetic, potential and elastic energy - dissipation) in % of the work, on its "
         "own scale with each value written; the tolerance is +-2%. " + _STIRRED),
    Plot("stirred_mill_regions", "stirred_mill:regions", "aggregate:stirred_mill",
         "Relative bead-bead collision frequency in 9 regions, rings 1-3 x front/centre/back "
         "(Fig. 8 of the LS1 paper), one panel per case, one colour scale for all "
         "panels. " + _STIRRED),
    Plot("stirred_mill_velocity", "stirred_mill:velocity", "aggregate:stirred_mill",
         "Coarse-grained translational (left, arrows: in-plane direction) and rotational (right) "
         "bead speed on an axial slab (Fig. 11 of the LS1 paper), one row per case; one colour "
         "scale per quantity for all cases, ending at the 99th percentile of the cells (the few "
         "cells above it, near walls and holes crossed by few beads, take the top "
         "colour). " + _STIRRED),
    Plot("stirred_mill_friction", "stirred_mill:friction", "table:stirred_mill_friction",
         "Power-draw calibration, stage 1 (Fig. 5 of the LS1 paper). a: dry power against speed "
         "per friction coefficient (95% intervals) with the reference (open squares). b: sum of "
         "squared residuals per friction (dots); its minimum is the calibrated friction (red "
         "line); "
         "black dashed: the refined friction, the vertex of the parabola through the minimum "
         "and its neighbours (blue dashed); shaded: the 95% interval, the frictions at which "
         "the power interpolated between the simulated ones stays within the combined "
         "simulation and reference intervals (millsim.analysis.stirred_mill.interval; an end "
         "at the edge of the grid is open, written <= or >=). " + _FEW + " " + _SYNTHETIC),
    Plot("stirred_mill_viscosity", "stirred_mill:viscosity", "table:stirred_mill_viscosity",
         "Power-draw calibration, stage 2 (Fig. 6 of the LS1 paper): power at the calibration "
         "speed against the simulation viscosity (95% intervals), with the reference power of each "
         "fluid at its measured viscosity (open squares) and, at that power, the 95% interval of "
         "the simulation viscosity consistent with it (bars; an end the simulated grid does not "
         "bracket is open, written <= or >= in the legend and drawn with an arrow). "
         + _SYNTHETIC),
    Plot("stirred_mill_prediction", "stirred_mill:prediction", "table:stirred_mill_prediction",
         "Power-draw calibration, stage 3 (Fig. 7 of the LS1 paper): power at the calibrated "
         "friction and simulation viscosities (filled circles) against the reference (open "
         "squares, dashed), one colour per fluid, with 95% intervals; legend below the axes. "
         + _FEW + " " + _SYNTHETIC),
    # ---- accuracy: error against run time ----
    Plot("error_vs_runtime_{name}", "accuracy:error_vs_runtime", "aggregate:accuracy",
         "Error against run time of one accuracy study: for each observable, the error of the mean "
         "over seeds against the converged reference (finest step, or Richardson extrapolation "
         "where the observable converges smoothly) as a function of the wall time of one case "
         "(the fastest of its seeds), one line per ladder (integrator, viscosity, mode); error "
         "bars: the standard error of the error (paired differences over seeds, pooled over the "
         "ladder); dotted: the statistical noise (standard deviation over seeds of one case at "
         "the reference step); dashed: the tolerance. Ringed: the series' default step (the "
         "cheapest step within the tolerance or not distinguishable from zero, for every deciding "
         "observable, at most limit_fraction of the stability limit); squared: the cheapest step "
         "for that observable alone. Right: the observable against the time step (mean +- sd "
         "over seeds) with the reference. docs/results/accuracy.md, \"How the numbers are made\"."),
)

PLOTS: dict[str, Plot] = {p.name: p for p in _ENTRIES}
assert len(PLOTS) == len(_ENTRIES), "a plot name is registered twice"
assert all(p.input.partition(":")[0] in INPUT_KINDS for p in _ENTRIES)
assert not any(c.isspace() for p in _ENTRIES for c in p.name + p.input)


def find(kind):
    """(registry entry, fields) of figure ``kind``; ValueError naming the known ones if none."""
    for entry in PLOTS.values():
        fields = entry.match(kind)
        if fields is not None:
            return entry, fields
    raise ValueError(f"kind: unknown plot {kind!r}; known: {', '.join(PLOTS)}")


def _read(entry, source):
    kind = entry.input.split(":")[0]
    if kind == "aggregate":
        from ..io import read_case

        ds = read_case(source)
        # a case has parameters_json (an aggregate of one case keeps it too) but no source_cases
        if "parameters_json" in ds.attrs and "source_cases" not in ds.attrs:
            raise ValueError(f"{source}: a case file; figure {entry.name} is drawn from an "
                             f"aggregate ({entry.input}, `millsim aggregate` writes one)")
        return ds
    if kind == "table":
        from ..io import read_table

        return read_table(source)
    return os.fspath(source)  # snapshots: the drawing function reads the frames itself


def plot(kind, source, out):
    """Draw figure ``kind`` from ``source`` (see the entry's input) to ``out``, atomically, in the
    one style of millsim.plots.style."""
    import matplotlib

    from ..io import atomic_target
    from .style import RC

    entry, fields = find(kind)
    data = _read(entry, source)
    with atomic_target(out) as tmp, matplotlib.rc_context(RC):
        try:
            entry.function()(data, os.fspath(tmp), **fields)
        except KeyError as exc:
            # a readable file of another kind: what the figure is drawn from is missing
            what = exc.args[0] if exc.args else exc
            what = what if isinstance(what, str) and " " in what else f"no {what!r}"
            raise ValueError(f"{source}: {what}; figure {kind} is drawn from {entry.input}") \
                from None


def listing():
    """The registry as ``millsim plot --list`` prints it: name, input, caption; tab-separated."""
    return "\n".join(f"{p.name}\t{p.input}\t{p.caption}" for p in PLOTS.values())
