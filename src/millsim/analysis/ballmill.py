"""Ball-mill (Buchholtz et al. 2000) summaries of the aggregate: size snapshots reduced per case,
the comminution rate relative to its maximum over n/n_c."""

import numpy as np
import xarray as xr

from .ballmill3d import peak_position

# Buchholtz, Freund & Poeschel (2000), Fig 6 and its text: the comminution rate is largest near
# n = n_c and diminishes rapidly for larger or smaller speeds. Our rules for "near" and "rapidly"
# (the paper gives no numbers): the vertex of the parabola through the highest rate and its
# neighbours within NEAR of 1, and the rate at n/n_c <= FAR_LOW and >= FAR_HIGH below
# FAR_FRACTION of the maximum.
NEAR = 0.25
FAR_LOW, FAR_HIGH, FAR_FRACTION = 0.5, 1.5, 0.25
BOND_AUSTIN_END = 1.232  # zero of the Bond/Austin speed factor


def bond_austin_factor(phi):
    """Speed factor phi (1 - 0.1 / 2^(9 - 10 phi)) of the Bond and Austin mill-power equations,
    unnormalised (reference/ballmill.md, sections 2.2-3): a reference shape for power draw, not
    for the comminution rate; it turns negative beyond phi = BOND_AUSTIN_END."""
    phi = np.asarray(phi, dtype=float)
    return phi * (1.0 - 0.1 / 2.0 ** (9.0 - 10.0 * phi))


def bond_austin_speed_factor(phi):
    """:func:`bond_austin_factor` normalised to its maximum (at phi = 0.941)."""
    return bond_austin_factor(phi) / bond_austin_factor(np.linspace(0.0, 1.2, 12001)).max()


def bond_austin_peak():
    """Fraction of critical speed at which the Bond/Austin factor peaks: the root of its
    derivative, 1 - 0.1 (1 + 10 phi ln 2) / 2^(9 - 10 phi) = 0, by bisection on [0.5, 1.2]."""
    def slope(p):
        return 1.0 - 0.1 * (1.0 + 10.0 * p * np.log(2.0)) / 2.0 ** (9.0 - 10.0 * p)

    lo, hi = 0.5, 1.2
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if slope(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def paper_claims(ds: xr.Dataset):
    """The paper's statements on the rate against speed, each with our number and whether it is
    followed: [(claim, our number, rule, "followed" | "not followed" | "not testable here")]."""
    speed = ds["n_over_nc"].values.astype(float)
    rate = ds["comminution_rate"].values.astype(float)
    peak = peak_position(speed, rate)
    top = float(speed[int(np.nanargmax(rate))]) if np.isfinite(rate).any() else np.nan
    claim = "maximum of the comminution rate near n = n_c (Fig 6)"
    if np.isfinite(peak):
        rows = [(claim, f"vertex at n/n_c = {peak:.3g} (highest point {top:.3g})",
                 f"abs(vertex - 1) <= {NEAR:g}",
                 "followed" if abs(peak - 1.0) <= NEAR else "not followed")]
    else:
        rows = [(claim, f"highest point at n/n_c = {top:.3g}, an end of the sweep",
                 "the sweep must bracket the maximum", "not testable here")]
    relative = rate / np.nanmax(rate)
    low, high = relative[speed <= FAR_LOW], relative[speed >= FAR_HIGH]
    claim = "rate diminishing rapidly for larger or smaller speeds (section 3.2)"
    if low.size and high.size:
        largest = max(float(np.nanmax(low)), float(np.nanmax(high)))
        rows.append((claim, f"relative rate <= {largest:.3g} at n/n_c <= {FAR_LOW:g} and "
                     f">= {FAR_HIGH:g}", f"below {FAR_FRACTION:g} of the maximum there",
                     "followed" if largest < FAR_FRACTION else "not followed"))
    else:
        rows.append((claim, "the sweep does not reach both sides", "", "not testable here"))
    if "mean_drive_power" in ds:
        power = peak_position(speed, ds["mean_drive_power"].values.astype(float))
        rows.append(("drive power against the Bond/Austin reference shape (power draw of "
                     "industrial mills; reference/ballmill.md 2-3)",
                     f"power vertex at n/n_c = {power:.3g}; Bond/Austin peak "
                     f"{bond_austin_peak():.3g}", "reported, not tested (2D disks)",
                     "not testable here"))
    return rows


def case_summary(ds: xr.Dataset) -> xr.Dataset:
    """Reduce the size snapshots of one ball-mill case to their mean and spread."""
    if "size_distribution" not in ds:
        return ds
    mass = ds["size_distribution"]
    fraction = mass / mass.sum("size_class")
    return ds.assign(
        size_distribution_mean=mass.mean("snapshot").assign_attrs(
            units=mass.attrs["units"], long_name="mass per size class, mean over snapshots"),
        mass_fraction=fraction.mean("snapshot").assign_attrs(
            units="1", long_name="mass fraction per size class, mean over snapshots"),
        mass_fraction_std=fraction.std("snapshot").assign_attrs(
            units="1", long_name="standard deviation of the mass fraction over snapshots"),
    )


def summary(ds: xr.Dataset) -> xr.Dataset:
    """Comminution rate relative to its maximum over n/n_c (as in Fig. 6
    of Buchholtz et al. 2000)."""
    if "chain_count" in ds:  # a chain length absent from one case was counted zero times there
        ds["chain_count"] = ds["chain_count"].fillna(0.0)
    if "comminution_rate" not in ds:
        return ds
    if "n_over_nc" not in ds.dims:
        raise ValueError("over: the ball-mill rate is normalised along n_over_nc; stack over it")
    peak = ds["comminution_rate"].max("n_over_nc")
    ds["relative_rate"] = (ds["comminution_rate"] / peak).assign_attrs(
        units="1", long_name="comminution rate relative to its maximum over n/n_c")
    # the maximum is taken as exact, so the relative interval is the absolute one scaled
    ds["relative_rate_ci"] = (ds["comminution_rate_ci"] / peak).assign_attrs(
        units="1", long_name="95% half-width of the relative comminution rate")
    return ds
