"""`master sweep` on a Dask cluster (README "Robustness sweeps on a cluster")."""
