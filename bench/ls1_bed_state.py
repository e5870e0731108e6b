"""What the bead bed of a running stirred-mill case looks like, from copies of its checkpoint
(issue 12: why the dry full-LS1 power at 3000 rpm rises again after 7 revolutions).

A case run with ``--checkpoint-every S`` rewrites ``OUT.ckpt`` every S seconds of wall time; copies
of it taken as the run goes are the bed's states at those times (the case file itself holds only
the power, the kinetic energy and the window's summaries). For each copy this prints, per radial
band between the shaft and the chamber wall:

- the beads' solid fraction (bead volume / band volume over the whole chamber length),
- their mean azimuthal velocity as a fraction of the agitator's rigid rotation, u_theta / (omega r),
- their velocity fluctuation about that mean (rms, m/s: the shearing that dissipates),

and for the bed as a whole its angular momentum about the axis over that of rigid rotation at the
agitator's speed, its centre of mass across the axis (gravity is -z) and the share of it below the
axis, and the beads per unit length of each compartment between the disks (or a disk
and a wall) over the chamber's mean.

With ``--fit-from REV`` it also fits rotation = level + amplitude exp(-(rev - REV) / tau) to the
states from revolution REV on (least squares, tau at most five times the states' span: a slower
decay is reported as a straight fall with no level; the level's standard error is the fit's,
which treats the states as independent) and prints it beside the rotation a bed needs to be held
at the wall, sqrt(g / R_c) / omega (the scene's g), and the fall per revolution
over the last revolution of states: is a falling wet bed levelling, and where?

    python bench/ls1_bed_state.py CKPT [CKPT ...] [--bands 6] [--json FILE] [--fit-from REV]
        [--until REV]

(a ``.json`` in place of checkpoints: the states an earlier ``--json`` wrote.)
"""
import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ls1_checkpoint_series import checkpoint_state  # noqa: E402


def bed_state(case, bands):
    sim, g = case.sim, case.g
    p = sim.particles
    bead = np.asarray(p.body) < 0
    x, v, r = np.asarray(p.x)[bead], np.asarray(p.v)[bead], np.asarray(p.radius)[bead]
    vol = 4.0 / 3.0 * np.pi * r**3
    y, z = x[:, 1], x[:, 2]
    rho = np.hypot(y, z)
    # azimuthal unit vector about the x axis: e_theta = (0, -z, y) / rho
    u_theta = (-z * v[:, 1] + y * v[:, 2]) / rho
    u_axial = v[:, 0]
    u_radial = (y * v[:, 1] + z * v[:, 2]) / rho
    omega = g["omega"] * min(1.0, sim.time / g["ramp"]) if g["ramp"] else g["omega"]
    R, r_shaft, length = g["chamber_radius"], g["shaft_radius"], g["length"]
    edges = np.linspace(r_shaft, R, bands + 1)
    which = np.clip(np.digitize(rho, edges) - 1, 0, bands - 1)
    rows = []
    for b in range(bands):
        m = which == b
        shell = np.pi * (edges[b + 1] ** 2 - edges[b] ** 2) * length
        if not m.any():
            rows.append(dict(r_lo=edges[b], r_hi=edges[b + 1], solid_fraction=0.0, n=0))
            continue
        w = vol[m]
        rel = np.average(u_theta[m] / (omega * rho[m]), weights=w)
        # about the band's mean rotation, radial drift 0 and its mean axial drift
        swirl = u_theta[m] - rel * omega * rho[m]
        axial = u_axial[m] - np.average(u_axial[m], weights=w)
        fluct = np.sqrt(np.average(swirl**2 + u_radial[m] ** 2 + axial**2, weights=w))
        rows.append(dict(r_lo=edges[b], r_hi=edges[b + 1], n=int(m.sum()),
                         solid_fraction=float(w.sum() / shell), rotation=float(rel),
                         fluctuation=float(fluct)))
    # angular momentum about the axis over rigid rotation at omega (equal bead density)
    rotation = float(np.sum(vol * rho * u_theta) / (omega * np.sum(vol * rho**2)))
    disk_x = np.asarray(g["disk_x"])
    cuts = np.concatenate([[g["x_lo"]], disk_x, [g["x_lo"] + length]])
    # beads per unit length of each compartment over the mean (the end ones are half a pitch long)
    density = np.histogram(x[:, 0], bins=cuts)[0] / np.diff(cuts)
    # gravity is -z: a bed that does not co-rotate enough to be held at the wall pools below
    centre = np.average(x[:, 1:], axis=0, weights=vol) / R
    return dict(time=float(sim.time), revolutions=float(sim.time * g["omega"] / (2 * np.pi)),
                omega=float(omega), rotation=rotation,
                mean_radius=float(np.average(rho, weights=vol)),
                centre_y=float(centre[0]), centre_z=float(centre[1]),
                below_axis=float(vol[z < 0].sum() / vol.sum()),
                bands=rows, compartments=(density / (len(x) / length)).round(3).tolist())


def rotation_trend(states, start, omega, chamber_radius):
    """The exponential fit and last revolution's slope described in the module's docstring."""
    from scipy.optimize import curve_fit

    from millsim.scenes.stirred_mill import G

    rev = np.array([s["revolutions"] for s in states if s["revolutions"] >= start])
    rot = np.array([s["rotation"] for s in states if s["revolutions"] >= start])
    if len(rev) < 4:
        raise SystemExit(f"--fit-from {start}: {len(rev)} states from there, the fit needs 4")

    def model(r, level, amplitude, tau):
        return level + amplitude * np.exp(-(r - start) / tau)

    span = rev[-1] - rev[0]
    # a decay slower than 5 spans is a straight fall over the span: no level can be read off
    tau_max = 5.0 * span
    guess = (rot[-1], rot[0] - rot[-1], 0.5 * span)
    (level, amplitude, tau), cov = curve_fit(model, rev, rot, p0=guess, maxfev=20000,
                                             bounds=([-np.inf, -np.inf, 0.01 * span],
                                                     [np.inf, np.inf, tau_max]))
    level_se = float(np.sqrt(cov[0, 0]))
    if tau > 0.99 * tau_max:
        level = level_se = float("nan")
    last = rev >= rev[-1] - 1.0
    slope = float(np.polyfit(rev[last], rot[last], 1)[0]) if last.sum() >= 2 else float("nan")
    return dict(fit_from=start, states=int(len(rev)), straight=bool(np.isnan(level)),
                level=float(level), level_se=level_se,
                amplitude=float(amplitude), tau_rev=float(tau),
                held_at_wall=float(np.sqrt(G / chamber_radius) / omega),
                slope_last_revolution=slope)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("checkpoints", nargs="+")
    ap.add_argument("--bands", type=int, default=6)
    ap.add_argument("--json", help="write the states to this JSON file")
    ap.add_argument("--fit-from", type=float, metavar="REV",
                    help="fit the rotation's decay from this revolution on (see above)")
    ap.add_argument("--until", type=float, metavar="REV",
                    help="only the states before this revolution (what a shorter run would show)")
    a = ap.parse_args(argv)
    states = []
    for path in a.checkpoints:
        if path.endswith(".json"):  # states saved by an earlier --json (any engine's)
            states += json.loads(Path(path).read_text())
            continue
        case, _, _ = checkpoint_state(path)
        s = bed_state(case, a.bands)
        s["file"] = str(path)
        states.append(s)
    states.sort(key=lambda s: s["time"])
    if a.until is not None:
        states = [s for s in states if s["revolutions"] < a.until]
    if not states:
        raise SystemExit(f"no state before revolution {a.until:g}")
    for s in states:
        print(f"t = {s['time'] * 1e3:7.2f} ms ({s['revolutions']:5.2f} rev): bed rotation "
              f"{s['rotation']:.3f} of rigid, mean radius {s['mean_radius'] * 1e3:.2f} mm, "
              f"centre (y, z) ({s['centre_y']:+.3f}, {s['centre_z']:+.3f}) R, "
              f"{s['below_axis']:.3f} of the beads below the axis; "
              f"compartments / mean {s['compartments']}")
        print("   r [mm]        solid fr.  u_theta/(omega r)  fluctuation [m/s]")
        for b in s["bands"]:
            if b["n"]:
                print(f"   {b['r_lo'] * 1e3:5.1f}-{b['r_hi'] * 1e3:5.1f}   "
                      f"{b['solid_fraction']:8.3f}  {b['rotation']:17.3f}  "
                      f"{b['fluctuation']:17.3f}")
            else:
                print(f"   {b['r_lo'] * 1e3:5.1f}-{b['r_hi'] * 1e3:5.1f}      empty")
    if a.fit_from is not None:
        # the agitator's full speed (revolutions count at it) and the chamber wall (last band's edge)
        omega = 2.0 * np.pi * states[-1]["revolutions"] / states[-1]["time"]
        f = rotation_trend(states, a.fit_from, omega, states[-1]["bands"][-1]["r_hi"])
        fit = (f"no level: the fall is straight over the span (tau at its bound, "
               f"{f['tau_rev']:.1f} rev)" if f["straight"] else
               f"level {f['level']:.4f} +- {f['level_se']:.4f} (fit's standard error), amplitude "
               f"{f['amplitude']:+.4f}, tau {f['tau_rev']:.2f} rev")
        print(f"rotation from revolution {a.fit_from:g} ({f['states']} states): {fit}; "
              f"held at the wall from "
              f"{f['held_at_wall']:.4f}; slope over the last revolution "
              f"{f['slope_last_revolution']:+.4f} per revolution")
    if a.json:
        Path(a.json).write_text(json.dumps(states, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
