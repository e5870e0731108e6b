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
one module per study (ballmill, animation, bed_impact, tavares, stirred_mill, accuracy), imported
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


_SYNTHETIC = ("The shipped reference (config/reference/stirred_mill_power.csv) is a synthetic twin "
              "produced by this engine, not a measurement; config/reference/SOURCES.md says how "
              "to drop in measured data.")
_STIRRED = ("Quick-study cases run a periodic slice around one disk of a geometrically scaled "
            "chamber (docs/stirred_mill.md).")

_ENTRIES = (
    # ---- ball mill 2D (seed 000) ----
    Plot("ballmill_rate", "ballmill:rate", "aggregate:ballmill",
         "Comminution rate (fracture events per second in steady state) relative to its maximum, "
         "against the rotation speed as a fraction of the critical speed n_c (Fig. 6 of seed "
         "000). Error bars: 95% confidence half-width from block averages. Line: the Bond/Austin "
         "speed factor phi(1 - 0.1/2^(9 - 10 phi)), normalised; an empirical shape for mill power, "
         "not for comminution rate, so only the shape is comparable. Lower panel: mean drive "
         "power."),
    Plot("ballmill_size_distributions", "ballmill:size_distributions", "aggregate:ballmill",
         "Fragment size distribution (Fig. 5 of seed 000): mass fraction of grains per radius "
         "class for each rotation speed. Line: mean over the recorded snapshots; band: one "
         "standard deviation over the snapshots (the temporal fluctuation)."),
    Plot("ballmill_fragmentation_maps", "ballmill:fragmentation_maps", "aggregate:ballmill",
         "Where grains break (Fig. 7 of seed 000): fracture events per second and unit area on a "
         "grid over the drum cross-section, one panel per rotation speed, common grey scale."),
    Plot("ballmill_pressure_maps", "ballmill:pressure_maps", "aggregate:ballmill_forcechain",
         "Time-averaged local pressure (Fig. 12 of seed 000) in the force-chain study, run "
         "without fragmentation: one panel per rotation speed, common grey scale."),
    Plot("ballmill_force_chains", "ballmill:force_chains", "aggregate:ballmill_forcechain",
         "Force-chain statistics (Figs. 10-11 of seed 000), run without fragmentation: number of "
         "chains per length, mean maximum pressure in a chain per length, and mean force against "
         "the relative position along a chain. One line per rotation speed."),
    Plot("animation", "animation:animation", "snapshots",
         "Animation of a case from its particle snapshots: grains coloured by speed, drum wall "
         "and lifter particles grey."),
    # ---- bed impact (seed 002 section 4.2) ----
    Plot("bed_broken_mass", "bed_impact:broken_mass", "aggregate:bed_breakage",
         "Broken mass (mass passing 4.75 mm, incl. dummy spheres and fines) after one impact of "
         "the 88 mm, 2.78 kg steel ball at 3.05 J (or the energy closest to it), per bed "
         "configuration and material, as seed 002 Fig. 22. Bars: mean over seeds (replicates); "
         "whiskers: standard deviation. Simulation only: the seed's measurements exist only as a "
         "figure and are not reproduced here."),
    Plot("bed_capture_radius", "bed_impact:capture_radius", "aggregate:bed_breakage",
         "Capture radius (largest horizontal distance from the ball's axis of an original bed "
         "particle that broke) against impact energy, as seed 002 Fig. 20. Line: mean over seeds; "
         "dots: single seeds."),
    Plot("bed_size_energy", "bed_impact:size_energy", "aggregate:bed_breakage",
         "Product size distribution (cumulative % passing, dummy spheres and unresolved fines "
         "spread below their size by eq 11) per impact energy, mean over seeds, as seed 002 "
         "Fig. 21."),
    Plot("bed_size_configuration", "bed_impact:size_configuration", "aggregate:bed_breakage",
         "Product size distribution per bed configuration at 3.05 J (or the closest energy), "
         "mean over seeds, as seed 002 Fig. 23."),
    # ---- Tavares single-particle verification (seed 002 section 4.1) ----
    Plot("tavares_probability", "tavares:probability", "aggregate:tavares_verification",
         "Breakage probability against the input (stressing) specific energy Ek/m of 5.5 mm "
         "particles, single impact on a steel plate (filled) and drop-weight test (open; striker "
         "and anvil contacts summed), as seed 002 Fig. 8. Lines: eq 1 at the absorbed energy "
         "k_s/(k_p+k_s) Ek/m; bars: 95% Clopper-Pearson intervals. Pass rule: the line inside the "
         "bar at >= 90% of points (results in the aggregate's attributes and log)."),
    Plot("tavares_repeated", "tavares:repeated", "aggregate:tavares_verification",
         "Cumulative fraction broken after each of n repeated impacts at one energy, for several "
         "damage coefficients gamma, as seed 002 Fig. 11. Lines: eqs 1-6 integrated over the "
         "fracture-energy distribution; symbols: simulation with 95% intervals."),
    Plot("tavares_t10", "tavares:t10", "aggregate:tavares_verification",
         "t10 of the broken particles' product (fines included) against input specific energy, as "
         "seed 002 Fig. 16. Solid: eq 7 with E50b the median of the broken particles; dotted: "
         "with the median of all; dashed: eq 9 (breakage at exactly the fracture energy, which the "
         "engine's first-crossing decision gives each event). Bars: 95% bootstrap intervals."),
    Plot("tavares_size_distributions", "tavares:size_distributions",
         "aggregate:tavares_verification",
         "Cumulative size distribution of the broken particles' product, dummy class spread below "
         "x_min by eq 11 (symbols), against eq 10 at the eq 7 t10 (lines), as seed 002 Figs "
         "13-15. Black dashed: smallest family size 0.21 d; red dashed: global minimum size d/20."),
    Plot("tavares_table2", "tavares:table2", "aggregate:tavares_verification",
         "Mean cumulative % passing of the progeny families generated for t10' = 3% against seed "
         "002 Table 2 and the eq 10 target (Table 1 average parameters)."),
    # ---- stirred media mill (seed 004) ----
    Plot("stirred_mill_power", "stirred_mill:power", "aggregate:stirred_mill",
         "Net power against agitator speed, one curve per simulation viscosity (95% block-mean "
         "intervals), from the aggregate of the power study. " + _STIRRED),
    Plot("stirred_mill_typology", "stirred_mill:typology", "aggregate:stirred_mill",
         "Dissipated energy by contact typology per case (stacked %, seed 004 Fig. 9) and the "
         "energy-balance residual (% of the agitator's input). " + _STIRRED),
    Plot("stirred_mill_regions", "stirred_mill:regions", "aggregate:stirred_mill",
         "Relative bead-bead collision frequency in 9 regions, rings 1-3 x front/centre/back "
         "(seed 004 Fig. 8). " + _STIRRED),
    Plot("stirred_mill_velocity", "stirred_mill:velocity", "aggregate:stirred_mill",
         "Coarse-grained translational and rotational bead speed on an axial slab (seed 004 "
         "Fig. 11). " + _STIRRED),
    Plot("stirred_mill_friction", "stirred_mill:friction", "table:stirred_mill_friction",
         "Power-draw calibration, stage 1 (seed 004 Fig. 5): dry power against speed per friction "
         "coefficient with the reference, and the sum of squared residuals per friction (its "
         "minimum is the calibrated friction). " + _SYNTHETIC),
    Plot("stirred_mill_viscosity", "stirred_mill:viscosity", "table:stirred_mill_viscosity",
         "Power-draw calibration, stage 2 (seed 004 Fig. 6): power at the calibration speed "
         "against the simulation viscosity, with the reference power of each fluid at its "
         "measured viscosity. " + _SYNTHETIC),
    Plot("stirred_mill_prediction", "stirred_mill:prediction", "table:stirred_mill_prediction",
         "Power-draw calibration, stage 3 (seed 004 Fig. 7): power curves at the calibrated "
         "friction and simulation viscosities against the reference, per fluid. " + _SYNTHETIC),
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
         "over seeds) with the reference. README section \"Accuracy: error against run time\"."),
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
