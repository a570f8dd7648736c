"""The dataset on disk: sharded Parquet rows and HDF5 media, a manifest, a reader.

``fallgen.dataset.open(path)`` returns a :class:`~fallgen.dataset.reader.Dataset`.
"""

from fallgen.dataset.reader import Dataset, open_dataset as open  # noqa: A001

__all__ = ["Dataset", "open"]
