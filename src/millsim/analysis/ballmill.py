"""Ball-mill (Buchholtz et al. 2000) summaries of the aggregate: size snapshots reduced per case,
the comminution rate relative to its maximum over n/n_c."""

import xarray as xr


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
