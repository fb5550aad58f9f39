"""``coverplan batch``: every building of a city model planned on a Dask cluster."""

from coverplan.batch.run import BatchResult, BatchSettings, run_batch

__all__ = ["BatchResult", "BatchSettings", "run_batch"]
