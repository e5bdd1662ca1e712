"""Fleets: fit and diagnose many records (one unit each) on Dask, one results table, a lot
report (``creepcomp fleet``, ``docs/fleet.md``)."""

from creepcomp.fleet.batch import SERIAL, WORKER_CONFIG, FleetResult, local_cluster, run
from creepcomp.fleet.discover import find_records, unit_names
from creepcomp.fleet.lot import lot_summary, robust_z
from creepcomp.fleet.table import COLUMNS, COLUMN_NAMES, arrow_table, write_table
from creepcomp.fleet.unit import OIML_C3_CREEP, process_unit, step_creep

__all__ = ["SERIAL", "WORKER_CONFIG", "FleetResult", "run", "local_cluster", "find_records",
           "unit_names", "lot_summary", "robust_z", "COLUMNS", "COLUMN_NAMES", "arrow_table",
           "write_table", "OIML_C3_CREEP", "process_unit", "step_creep"]
