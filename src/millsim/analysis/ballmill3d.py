"""3D ball-mill study (scene ballmill3d): the aggregate's summaries and the published references.

``millsim aggregate ballmill3d`` stacks the cases over n_over_nc x filling; :func:`case_summary`
reduces each case's product size distribution against time to its first and last record, and
:func:`summary` adds, per case and per filling, what the study compares:

- **Charge shape, Morrell (1996b).** Toe and shoulder angles of the charge as fitted to
  measurements by Morrell (1993, 1996b), in Morrell's convention (radians from the horizontal,
  increasing in the direction of rotation, the toe below and the shoulder above the horizontal)::

      phi_c   = 0.35 (3.364 - J)      (the speed fraction at which the charge is centrifuged;
                                       phi_c - phi is taken as 0 above it)
      theta_T = 2.5307 (1.2796 - J) (1 - exp(-19.42 (phi_c - phi))) + pi/2
      theta_S = pi/2 - (theta_T - pi/2) ((0.3386 + 0.1041 phi) + (1.54 - 2.5673 phi) J)

  with J the fractional filling of the mill by the charge (bulk, voids included) and phi the
  fraction of the critical speed 42.3/sqrt(D) rpm (D in m: sqrt(2 g / D) rad/s, the ball
  radius not subtracted). The scene's angles (contract: from the vertical below the axis,
  positive in the direction of rotation) are theta_T - 3 pi/2 and theta_S + pi/2.
- **Net power, Morrell's C-model (Morrell 1996b).** The charge as a body between the shell
  and an inner surface of radius r_i, lifted from toe to shoulder; for a dry mill (grate
  discharge: no slurry pool below the toe) the power of the cylindrical section is::

      P = pi g L N r_m / (3 (r_m - z r_i)) [2 r_m^3 - 3 z r_m^2 r_i + r_i^3 (3 z - 2)]
          rho_c (sin theta_S - sin theta_T)
        + L rho_c (pi N r_m / (r_m - z r_i))^3 [(r_m - z r_i)^4 - r_i^4 (z - 1)^4]

      z = (1 - J)^0.4532,  r_i = r_m sqrt(1 - 2 pi beta J / (2 pi + theta_S - theta_T)),
      beta = t_c / (t_f + t_c),  t_c = (2 pi - theta_T + theta_S) / (2 pi N/2),
      t_f = sqrt(2 r_mean (sin theta_S - sin theta_T) / g),
      r_mean = r_m/2 (1 + sqrt(1 - 2 pi J / (2 pi + theta_S - theta_T)))

  with N the mill speed [rev/s], r_m = D/2, L the length and rho_c the bulk density of the
  charge (charge mass / (J pi r_m^2 L)). An industrial model and a small DEM mill differ in
  absolute power, so the study compares SHAPES: the model is scaled to each filling's simulated
  powers by least squares (``power_reference_scale``, 1 = the model's absolute power).

Where the simulated power peaks is interpolated (:func:`peak_position`: the vertex of the
parabola through the highest point and its two neighbours; NaN where the highest point is at the
end of the sweep, so that no maximum is claimed the sweep does not bracket) and compared with
PEAK_RANGE, where tumbling-mill power is known to peak (the issue's 0.7-0.9 of critical; Hogg &
Fuerstenau 1972, Morrell 1996b). :func:`peak_claim` decides that statement with the powers'
95 % half-widths (the rule in its docstring), for the results page and the report alike.

The coefficients above are those of Morrell (1996b) as used by the JKMRC (Napier-Munn et al.
1996, ch. 6); the paper itself was not at hand: they were checked against three independent
public implementations of the model, which agree to every digit.

Hogg, R., Fuerstenau, D.W. (1972). Power relations for tumbling mills. Trans. SME-AIME 252,
418-423. Morrell, S. (1993). The prediction of power draw in wet tumbling mills. PhD thesis,
University of Queensland. Morrell, S. (1996b). Power draw of wet tumbling mills and its
relationship to charge dynamics, Part 2: an empirical approach to modelling of charge shape,
power draw and wear. Trans. Instn Min. Metall. C 105, C54-C62. Napier-Munn, T.J., Morrell,
S., Morrison, R.D., Kojovic, T. (1996). Mineral Comminution Circuits. JKMRC, Brisbane.
"""

import numpy as np
import xarray as xr

G = 9.81  # [m s-2]
SPEED, FILLING = "n_over_nc", "filling"
PEAK_RANGE = (0.7, 0.9)  # fraction of critical speed where mill power peaks (the issue)
FOLLOWED, NOT_FOLLOWED, NOT_TESTABLE = "followed", "not followed", "not testable here"
# the rule of peak_claim in words, for the report and the results page alike
_LO, _HI = PEAK_RANGE
PEAK_RULE = (f"the highest power clear of its neighbours' 95 % intervals and the vertex of the "
             f"parabola through the three in [{_LO:g}, {_HI:g}]; else not followed where the "
             "intervals place the maximum outside, not testable where partly "
             "(millsim.analysis.ballmill3d.peak_claim)")
ENERGY_BALANCE_TOLERANCE = 0.02  # |residual| / drive work, the scene's check (issue 52, item 3)
SPECTRA_AUDIT_TOLERANCE = 0.01  # |spectra - audit| / audit (issue 52, item 3)
# the two energy books checked on every case, for the report and the results page alike:
# variable -> (what it checks, tolerance, its name in this module)
ENERGY_BOOKS = {
    "energy_balance_error": ("drive work = dissipation + change of kinetic and potential energy",
                             ENERGY_BALANCE_TOLERANCE, "ENERGY_BALANCE_TOLERANCE"),
    "spectra_audit_error": ("collision energies of the spectra = the energy audit's dissipation",
                            SPECTRA_AUDIT_TOLERANCE, "SPECTRA_AUDIT_TOLERANCE"),
}
# per-record variables of a case, reduced to their first and last record (case_summary)
RECORD_DIM = "record_time"


def morrell_centrifuge_fraction(filling):
    """phi_c = 0.35 (3.364 - J) of Morrell (1996b): the fraction of sqrt(2 g / D) at and above
    which his relations take the charge as centrifuged (toe and shoulder at the top)."""
    return 0.35 * (3.364 - np.asarray(filling, float))


def morrell_angles(phi, filling):
    """Toe and shoulder angles (theta_T, theta_S) [rad] of Morrell (1996b) in his convention:
    from the horizontal, increasing in the direction of rotation; ``phi`` the fraction of the
    critical speed sqrt(2 g / D), ``filling`` the fractional filling J."""
    phi, filling = np.broadcast_arrays(np.asarray(phi, float), np.asarray(filling, float))
    phi_c = morrell_centrifuge_fraction(filling)
    lag = np.maximum(phi_c - phi, 0.0)  # above phi_c the charge is centrifuged: toe at pi/2
    toe = 2.5307 * (1.2796 - filling) * (1.0 - np.exp(-19.42 * lag)) + np.pi / 2
    shoulder = np.pi / 2 - (toe - np.pi / 2) * ((0.3386 + 0.1041 * phi)
                                                + (1.54 - 2.5673 * phi) * filling)
    return toe, shoulder


def morrell_toe_shoulder(phi, filling):
    """Morrell's toe and shoulder angles [rad] in the scene's convention: from the vertical
    below the axis, positive in the direction of rotation (the toe negative)."""
    toe, shoulder = morrell_angles(phi, filling)
    return toe - 1.5 * np.pi, shoulder + 0.5 * np.pi


def morrell_net_power(phi, filling, diameter, length, charge_density, g=G):
    """Net power [W] of the cylindrical section of a dry (grate-discharge) tumbling mill by
    Morrell's C-model (1996b; module docstring); ``phi`` the fraction of sqrt(2 g / D)."""
    toe, shoulder = morrell_angles(phi, filling)
    phi, filling = np.broadcast_arrays(np.asarray(phi, float), np.asarray(filling, float))
    r_m = 0.5 * diameter
    speed = phi * np.sqrt(2.0 * g / diameter) / (2.0 * np.pi)  # N [rev/s]
    span = 2.0 * np.pi + shoulder - toe  # angular extent of the charge
    lift = np.sin(shoulder) - np.sin(toe)
    r_mean = 0.5 * r_m * (1.0 + np.sqrt(1.0 - 2.0 * np.pi * filling / span))
    with np.errstate(divide="ignore", invalid="ignore"):
        t_c = span / (np.pi * speed)  # the charge turns at N/2 on average
        t_f = np.sqrt(2.0 * r_mean * np.maximum(lift, 0.0) / g)
        beta = np.where(speed > 0, t_c / (t_f + t_c), 1.0)
    r_i = r_m * np.sqrt(1.0 - 2.0 * np.pi * beta * filling / span)
    z = (1.0 - filling) ** 0.4532
    arm = r_m - z * r_i
    lifting = (np.pi * g * length * speed * r_m / (3.0 * arm)
               * (2.0 * r_m ** 3 - 3.0 * z * r_m ** 2 * r_i + r_i ** 3 * (3.0 * z - 2.0))
               * charge_density * lift)
    kinetic = (length * charge_density * (np.pi * speed * r_m / arm) ** 3
               * (arm ** 4 - r_i ** 4 * (z - 1.0) ** 4))
    return lifting + kinetic


def peak_position(x, y):
    """Abscissa of the maximum of ``y(x)``: the vertex of the parabola through the highest
    finite point and its two neighbours; NaN where that point is the first or last one (the
    sweep does not bracket the maximum) or fewer than 3 points are finite."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    order = np.argsort(x)
    x, y = x[order], y[order]
    k = int(np.argmax(y)) if y.size else 0
    if y.size < 3 or k in (0, y.size - 1):
        return np.nan
    a, b, _ = np.polyfit(x[k - 1:k + 2], y[k - 1:k + 2], 2)
    return float(-b / (2.0 * a))


def peak_claim(x, y, half_width, band=PEAK_RANGE):
    """Whether the maximum of the power ``y(x)`` (95 % half-widths ``half_width``; NaN: unknown)
    lies in ``band``: a dict of ``verdict`` ("followed", "not followed", "not testable here"),
    ``vertex`` (:func:`peak_position`), ``top`` (x of the highest y), ``bracket`` and ``reason``.

    Two powers differ when their intervals are disjoint (y_i - h_i > y_j + h_j). With the power
    taken as rising to one maximum and falling after it, a later power above an earlier one
    puts the maximum after the earlier speed, an earlier power above a later one before the
    later speed: ``bracket`` = (a, b), the tightest such bounds (-inf, inf where none).

    - the highest power above both neighbours' intervals: followed if the vertex lies in
      ``band`` (ends included), not followed otherwise;
    - else not followed where the bracket lies outside ``band`` (a >= its top, e.g. a power
      still rising beyond 0.9; or b <= its bottom);
    - else not testable: fewer than 3 speeds, a fall before a rise (a >= b: no single maximum),
      or the intervals leave the maximum in a bracket that reaches outside ``band`` (the highest
      power at an end of the sweep, or its interval overlapping a neighbour's)."""
    x, y, h = (np.asarray(v, float) for v in np.broadcast_arrays(x, y, half_width))
    ok = np.isfinite(x) & np.isfinite(y)
    order = np.argsort(x[ok])
    x, y = x[ok][order], y[ok][order]
    h = np.where(np.isfinite(h[ok][order]), np.abs(h[ok][order]), np.inf)  # unknown: no difference
    lo, hi = band
    out = {"vertex": peak_position(x, y), "top": np.nan, "bracket": (-np.inf, np.inf)}
    if x.size < 3:
        return out | {"verdict": NOT_TESTABLE, "reason": f"{x.size} speeds with a power; 3 needed"}
    k = int(np.argmax(y))
    out["top"] = float(x[k])
    clear = (y - h)[:, None] > (y + h)[None, :]  # clear[i, j]: power i above power j
    later = np.triu(np.ones_like(clear), 1)  # i < j
    rises = (clear.T & later).any(axis=1)  # a later power above power i: the maximum after x_i
    falls = (clear & later).any(axis=0)  # an earlier power above power j: the maximum before x_j
    a = float(x[rises].max()) if rises.any() else -np.inf
    b = float(x[falls].min()) if falls.any() else np.inf
    out["bracket"] = (a, b)
    where = f"[{lo:g}, {hi:g}]"
    if a >= b:
        return out | {"verdict": NOT_TESTABLE, "reason": f"the power falls (before {b:g}) and "
                      f"rises again (after {a:g}) beyond its half-widths: no single maximum"}
    if 0 < k < x.size - 1 and clear[k, k - 1] and clear[k, k + 1]:
        inside = lo <= out["vertex"] <= hi
        return out | {"verdict": FOLLOWED if inside else NOT_FOLLOWED,
                      "reason": f"the highest power ({x[k]:g}) clear of both neighbours' "
                                f"intervals; its vertex {'in' if inside else 'outside'} {where}"}
    if a >= hi or b <= lo:
        side = f"still rises after {a:g}" if a >= hi else f"has fallen by {b:g}"
        return out | {"verdict": NOT_FOLLOWED,
                      "reason": f"the power {side} beyond its half-widths: maximum outside {where}"}
    if k in (0, x.size - 1):
        why = f"the highest power at the {'first' if k == 0 else 'last'} speed ({x[k]:g})"
    else:
        near = [f"{x[i]:g}" for i in (k - 1, k + 1) if not clear[k, i]]
        why = f"the highest power's interval ({x[k]:g}) overlaps that at {' and '.join(near)}"
    return out | {"verdict": NOT_TESTABLE,
                  "reason": f"{why}: the maximum lies in ({a:g}, {b:g}), partly outside {where}"}


def book_check(ds: xr.Dataset, name: str) -> dict | None:
    """One energy book of :data:`ENERGY_BOOKS` over every case of ``ds``: ``check`` (in words),
    ``rule``, ``worst`` (the signed relative error of largest size), ``outside`` and ``cases``
    (how many of how many finite ones miss the tolerance) and ``passed`` (None where no case has
    a finite value); None where the aggregate lacks the variable."""
    if name not in ds:
        return None
    check, tolerance, constant = ENERGY_BOOKS[name]
    values = np.asarray(ds[name].values, float).ravel()
    values = values[np.isfinite(values)]
    rule = (f"relative error within +-{100 * tolerance:g} % in every case "
            f"(millsim.analysis.ballmill3d.{constant})")
    if not values.size:
        return dict(check=check, rule=rule, worst=np.nan, outside=0, cases=0, passed=None)
    outside = int((np.abs(values) > tolerance).sum())
    return dict(check=check, rule=rule, worst=float(values[np.argmax(np.abs(values))]),
                outside=outside, cases=int(values.size), passed=outside == 0)


def case_summary(ds: xr.Dataset) -> xr.Dataset:
    """The product size distribution of one case at its first and last record (the records'
    times differ between speeds, so the records themselves stay in the case file)."""
    if "passing_fraction" not in ds:
        return ds
    passing = ds["passing_fraction"]
    units = passing.attrs.get("units", "1")
    first, last = passing.isel({RECORD_DIM: 0}), passing.isel({RECORD_DIM: -1})
    out = ds.assign(
        passing_fraction_feed=first.drop_vars(RECORD_DIM).assign_attrs(
            units=units, long_name="cumulative ore mass fraction passing, first record"),
        passing_fraction_product=last.drop_vars(RECORD_DIM).assign_attrs(
            units=units, long_name="cumulative ore mass fraction passing, last record"),
        product_time=xr.DataArray(float(ds[RECORD_DIM][-1]), attrs={
            "units": "s", "long_name": "time of the last size-distribution record"}),
    )
    return out.drop_vars([n for n, v in out.variables.items() if RECORD_DIM in v.dims])


def _param(ds, name):
    """A parameter fixed for the whole study (kept by the stacking as attribute param_<name>)."""
    try:
        return float(ds.attrs[f"param_{name}"])
    except KeyError:
        raise ValueError(f"{name}: not one value for the whole study; the Morrell references "
                         f"need one {name} (stack over n_over_nc and filling only)") from None


def reference_inputs(ds: xr.Dataset):
    """(phi, charge density) of every case for Morrell's model: phi = omega / sqrt(2 g / D),
    rho_c = charge mass / (J pi D^2/4 L)."""
    diameter, length = _param(ds, "drum_diameter"), _param(ds, "drum_length")
    phi = ds["omega"] / np.sqrt(2.0 * G / diameter)
    density = ds["charge_mass"] / (ds[FILLING] * np.pi * diameter ** 2 / 4.0 * length)
    return phi, density


def reference_power(ds: xr.Dataset, speeds=None) -> xr.DataArray:
    """Morrell's net power scaled to each filling (``power_reference_scale``) at ``speeds``
    (n/n_c; default the study's). phi is n/n_c times each filling's mean ratio phi / (n/n_c)
    of its cases, the charge density their mean."""
    phi, density = reference_inputs(ds)
    ratio = (phi / ds[SPEED]).mean(SPEED)
    speeds = ds[SPEED] if speeds is None else xr.DataArray(np.asarray(speeds, float), dims=SPEED,
                                                           coords={SPEED: speeds})
    phi = (speeds * ratio).transpose(SPEED, FILLING)
    filling, density = (v.broadcast_like(phi).transpose(*phi.dims)
                        for v in (ds[FILLING], density.mean(SPEED)))
    power = morrell_net_power(phi.values, filling.values, _param(ds, "drum_diameter"),
                              _param(ds, "drum_length"), density.values)
    return phi.copy(data=power).assign_attrs(units="W") * ds["power_reference_scale"]


def summary(ds: xr.Dataset) -> xr.Dataset:
    """Morrell's toe, shoulder and scaled net power beside every case, the least-squares scale
    of the power model and the interpolated speed of the simulated and model power maxima per
    filling; checks that the impact spectra of the cases share their energy bins."""
    for name in ("impact_rate_normal", "impact_rate_tangential"):
        # rates are finite in every case: a NaN is a bin of one case missing in another
        if name in ds and bool(ds[name].isnull().any()):
            raise ValueError(f"{name}: the cases have different energy bins (energy_edge); "
                             "aggregate cases of one spectrum setting")
    if not {SPEED, FILLING} <= set(ds.dims):
        raise ValueError("over: the 3D ball-mill study is stacked over n_over_nc and filling")
    if "power" not in ds:
        return ds
    phi, density = reference_inputs(ds)
    phi = phi.transpose(SPEED, FILLING)
    filling, density = (v.broadcast_like(phi).transpose(*phi.dims) for v in (ds[FILLING], density))

    def like(values):  # the model's numpy result on the cases' (n_over_nc, filling) grid
        return phi.copy(data=np.asarray(values, float)).assign_attrs({})

    toe, shoulder = map(like, morrell_toe_shoulder(phi.values, filling.values))
    rad = {"units": "rad"}
    ds["phi_morrell"] = phi.assign_attrs(
        units="1", long_name="fraction of the critical speed sqrt(2 g / D) (Morrell 1996b)")
    ds["toe_angle_morrell"] = toe.assign_attrs(
        rad, long_name="toe angle by Morrell (1996b), from the vertical below the axis, "
                       "positive in the direction of rotation")
    ds["shoulder_angle_morrell"] = shoulder.assign_attrs(
        rad, long_name="shoulder angle by Morrell (1996b), from the vertical below the axis, "
                       "positive in the direction of rotation")
    model = like(morrell_net_power(phi.values, filling.values, _param(ds, "drum_diameter"),
                                   _param(ds, "drum_length"), density.values))
    ds["power_morrell"] = model.assign_attrs(
        units="W", long_name="net power by Morrell's C-model (1996b), dry, unscaled")
    sim = ds["power"]
    both = sim.notnull() & model.notnull()
    ds["power_reference_scale"] = ((sim * model).where(both).sum(SPEED)
                                   / (model ** 2).where(both).sum(SPEED)).assign_attrs(
        units="1", long_name="least-squares factor from Morrell's net power to the simulated")
    ds["power_reference"] = (model * ds["power_reference_scale"]).assign_attrs(
        units="W", long_name="Morrell's net power scaled by power_reference_scale")
    ds["power_peak_speed"] = xr.DataArray(
        [peak_position(ds[SPEED], sim.sel({FILLING: j})) for j in ds[FILLING].values],
        dims=FILLING, attrs={"units": "1", "long_name": "n/n_c of the simulated power "
                             "maximum (parabola vertex; NaN where the sweep does not bracket it)"})
    dense = np.linspace(0.3, 1.2, 901)
    curve = reference_power(ds, dense)
    peak = curve.idxmax(SPEED)
    ds["power_reference_peak_speed"] = peak.drop_vars(
        [c for c in peak.coords if c != FILLING]).assign_attrs(
        units="1", long_name="n/n_c of the maximum of Morrell's net power")
    return ds
