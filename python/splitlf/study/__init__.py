"""Studies of designs: the evaluation layer (merits), sweeps, inverse design (optimise),
the architecture comparison and the report. May import every domain below it; its
optional dependencies (xarray, pandas, SciPy, Dask) load on first use."""
