"""Input and output: configuration (TOML), trajectories (HDF5), logs (parquet) and VTK export."""
