"""Converters from the real SLAM data sets in the shared data directory to `SlamSequence`.

`SEQUENCES` maps a bag name to a loader taking the root data directory (the folder holding
`ttk4250_simulated_slam/`, `dlr_spatial_cognition/`, `utias_mrclam_ds1_robot1/`,
`utias_mrclam_ds1_robot2/`, `victoria_park/` and `acfr_car_park/`); `DEFAULT_DATA_DIRECTORY` is
that folder next to the repository (<repo>/../shared/data).
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from . import acfr_car_park, dlr, mrclam, ttk4250, victoria_park
from .sequence import CLUTTER, SlamSequence, SlamStep

DEFAULT_DATA_DIRECTORY = Path(__file__).resolve().parents[4] / 'shared' / 'data'
"""<repo>/../shared/data: this file is <repo>/data_association_ros/bag/datasets/__init__.py."""

CLUTTER_SEED = 4250
"""numpy default_rng seed of the clutter added to the simulated data set."""


def _ttk4250(root: Path) -> SlamSequence:
    return ttk4250.load(Path(root) / ttk4250.FOLDER)


def _ttk4250_clutter(per_scan: int) -> Callable[[Path], SlamSequence]:
    def load(root: Path) -> SlamSequence:
        return ttk4250.with_clutter(_ttk4250(root), per_scan, CLUTTER_SEED + per_scan)
    return load


SEQUENCES: dict[str, Callable[[Path], SlamSequence]] = {
    'ttk4250_simulated': _ttk4250,
    'ttk4250_simulated_clutter5': _ttk4250_clutter(5),
    'ttk4250_simulated_clutter20': _ttk4250_clutter(20),
    'dlr_spatial_cognition': lambda root: dlr.load(Path(root) / dlr.FOLDER),
    'mrclam_robot1': lambda root: mrclam.load(Path(root) / mrclam.FOLDER),
    'mrclam_robot2': lambda root: mrclam.load(Path(root) / mrclam.ROBOT2_FOLDER, robot=2),
    'victoria_park': lambda root: victoria_park.load(Path(root) / victoria_park.FOLDER),
    'acfr_car_park': lambda root: acfr_car_park.load(Path(root) / acfr_car_park.FOLDER),
}
"""Bag name -> loader(root data directory) -> SlamSequence."""

__all__ = ['CLUTTER', 'DEFAULT_DATA_DIRECTORY', 'SEQUENCES', 'SlamSequence', 'SlamStep']
