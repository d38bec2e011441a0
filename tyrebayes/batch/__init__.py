"""Fleet runs on dask.distributed: many drive logs to per-tyre-set and fleet posteriors.

Stages (:func:`fleet_run`): per drive (:func:`process_drive`: read → validate → features →
windows table + summary row), per tyre set (:func:`fit_tyre_set`: the joint fit of its drives
from their windows tables), fleet (:func:`run_fleet_stage`). Inputs from a manifest
(:func:`read_manifest`); the cluster from :func:`dask_client` (a ``LocalCluster`` by default, any
cluster by address). :func:`with_drive_cornering` puts a run's drive summaries' lateral work on
each tyre set's own c_y (what ``fit-wear`` reads them with).
"""

from .cluster import dask_client as dask_client
from .drive_stage import process_drive as process_drive
from .drive_summary import drive_summary as drive_summary
from .fleet_stage import fleet_table as fleet_table
from .fleet_stage import run_fleet_stage as run_fleet_stage
from .lateral import with_drive_cornering as with_drive_cornering
from .manifest import DriveItem as DriveItem
from .manifest import manifest_from_table as manifest_from_table
from .manifest import read_manifest as read_manifest
from .run import fleet_run as fleet_run
from .run_result import FleetRunResult as FleetRunResult
from .settings import RunSettings as RunSettings
from .tyre_set_stage import fit_tyre_set as fit_tyre_set
from .windows import WINDOW_COLUMNS as WINDOW_COLUMNS
from .windows import drives_from_windows as drives_from_windows
from .windows import windows_table as windows_table
