"""The dataset on disk: sharded Parquet rows and HDF5 media."""
